"""The simulation engine: plant, sensor, controller and disturbance in one loop.

Two ways to run a controller (SPEC.md section 2):

``mode="sampled"`` (default)
    The controller is evaluated at its sample instants ``t_k = k Ts`` on the sensor's
    measurement and its output held constant (zero-order hold) while the plant is integrated
    over ``Ts / dt`` steps by the compiled kernel (:mod:`mwip.sim.kernel`). This is the robot's
    loop (Ts = 5 ms) and, with ``Ts = dt``, the quasi-continuous loop used for the book's
    simulation studies with dynamic controllers (observers, adaptive laws).

``mode="continuous"``
    For a *static* law (``controller.static``), the law is evaluated inside the plant's
    right-hand side, as in a MATLAB ODE function. The closed loop can be far stiffer than the
    plant (the book's LQR places poles near -1e5 rad/s), so the ROS2 step uses the full
    Jacobian of the closed-loop right-hand side (finite differences, refreshed every ``Ts``)
    and is L-stable; records are taken every ``Ts``. Ideal measurements only.

A batch of N plants (each with its own parameters and initial state) runs through the same
code: the per-step work is compiled and the per-sample controller work is vectorised over N.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.budget import DEFAULT as DEFAULT_BUDGET
from mwip.budget import Budget, estimate
from mwip.core import Actuator, Controller, Sensor
from mwip.laws.packing import PackedLaw
from mwip.models.reduced import coefficients
from mwip.params import REAL, Params
from mwip.sim import aot
from mwip.sim.codes import GAMMA, METHOD_NAMES, OK, PARALLEL_MIN, RK4, ROS2W, STATUS_NAMES
from mwip.sim.disturbance import Disturbance
from mwip.sim.result import SimResult
from mwip.sim.sensors import IdealSensor
from mwip.validate import finite_array, integer, real

__all__ = [
    "simulate", "DEFAULT_TS", "DEFAULT_DT", "DEFAULT_DT_RK4", "RK4_MAX_HRHO", "initial_state",
    "fastest_rate", "choose_integrator",
]  # fmt: skip

DEFAULT_TS = 0.005
#: Default integration step (s) of ROS2-W on a stiff plant. Chosen from the step-halving study
#: in docs/engine.md: with ROS2-W at 0.5 ms a closed-loop LQR run on the literal-reading plant
#: differs from the 0.25 ms run by < 1e-4 (1 ms: ~4e-4 in the rates, from the fast damping
#: transients after each input step).
DEFAULT_DT = 0.0005
#: Default step (s) of RK4 on a non-stiff plant (capped at ``Ts``): from the convergence study
#: in docs/engine.md (benchmarks/convergence.py).
DEFAULT_DT_RK4 = 0.005
#: RK4 is chosen when ``dt`` times the plant's fastest linear rate is at most this (RK4's
#: stability interval on the negative real axis is 2.785; at 1 the fastest mode's one-step
#: factor is 0.375 against exp(-1) = 0.368).
RK4_MAX_HRHO = 1.0


def fastest_rate(coef: NDArray[np.float64]) -> float:
    """The largest ``|lambda|`` (rad/s) of the plant linearised about upright at rest, over the
    batch: the ``(psi, theta)`` block ``[[0, I], [M0^-1 K, -M0^-1 D]]`` of (2.33) (``K`` the
    gravity stiffness ``Gb`` on ``theta``, ``D`` the damping of (2.32)) and the yaw rate
    ``2 b^2 (Db + Dw) / (r^2 m33)``. Units reading: ~24 rad/s; literal reading: ~3000 rad/s."""
    c = np.asarray(coef, dtype=float).reshape(-1, 10)
    key = c.tobytes() if c.shape[0] <= 4 else None  # single runs: computed once per plant
    if key is not None and key in _RATE_CACHE:
        return _RATE_CACHE[key]
    m11, m12, m22, m33, _, Gb, Db, Dw, b, r = c.T
    n = c.shape[0]
    M = np.empty((n, 2, 2))
    M[:, 0, 0], M[:, 0, 1], M[:, 1, 0], M[:, 1, 1] = m11, m12, m12, m22
    K = np.zeros((n, 2, 2))
    K[:, 1, 1] = Gb
    D = np.empty((n, 2, 2))
    D[:, 0, 0], D[:, 0, 1], D[:, 1, 0], D[:, 1, 1] = 2 * (Dw + Db), -2 * Db, -2 * Db, 2 * Db
    Minv = np.linalg.inv(M)
    A = np.zeros((n, 4, 4))
    A[:, 0:2, 2:4] = np.eye(2)
    A[:, 2:4, 0:2] = Minv @ K
    A[:, 2:4, 2:4] = -Minv @ D
    rho = np.max(np.abs(np.linalg.eigvals(A)))
    yaw = np.max(2.0 * b * b * (Db + Dw) / (r * r * m33))
    out = float(max(rho, yaw))
    if key is not None and len(_RATE_CACHE) < 256:
        _RATE_CACHE[key] = out
    return out


_RATE_CACHE: dict[bytes, float] = {}


def choose_integrator(
    coef: NDArray[np.float64], Ts: float, dt: float | None, integrator: str = "auto"
) -> tuple[int, float]:
    """The method code (:data:`~mwip.sim.kernel.ROS2W` or :data:`~mwip.sim.kernel.RK4`) and the
    step for a sampled run.

    ``"auto"``: RK4 when ``dt * fastest_rate <= RK4_MAX_HRHO`` (the plant is not stiff at this
    step), else ROS2-W. Without ``dt`` the candidate is ``min(Ts, DEFAULT_DT_RK4)`` for RK4 and
    ``min(Ts, DEFAULT_DT)`` for ROS2-W, shortened to divide ``Ts``.
    """
    if integrator not in ("auto", "rk4", "ros2w"):
        raise ValueError(f"integrator must be 'auto', 'rk4' or 'ros2w', got {integrator!r}")

    def fit(h: float) -> float:
        h = min(Ts, h)
        return h if abs(round(Ts / h) * h - Ts) <= 1e-9 * Ts else Ts / np.ceil(Ts / h)

    if integrator == "ros2w":
        return ROS2W, fit(DEFAULT_DT) if dt is None else dt
    if integrator == "rk4":
        return RK4, fit(DEFAULT_DT_RK4) if dt is None else dt
    rho = fastest_rate(coef)
    h = fit(DEFAULT_DT_RK4) if dt is None else dt
    if h * rho <= RK4_MAX_HRHO:
        return RK4, h
    return ROS2W, fit(DEFAULT_DT) if dt is None else dt


def initial_state(
    n: int,
    q0: ArrayLike = (0.0, 0.0, 0.0),
    qdot0: ArrayLike = (0.0, 0.0, 0.0),
    pos0: ArrayLike = (0.0, 0.0),
) -> NDArray[np.float64]:
    """Stack initial conditions into the engine's state (n, 8), broadcasting each part."""
    y = np.zeros((n, 8))
    for sl, val, name, width in (
        (slice(0, 3), q0, "q0", 3),
        (slice(3, 6), qdot0, "qdot0", 3),
        (slice(6, 8), pos0, "pos0", 2),
    ):
        a = finite_array(name, val)
        if a.shape[-1:] != (width,) or a.ndim > 2:
            raise ValueError(f"{name} must have shape ({width},) or (N, {width}), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite")
        try:
            y[:, sl] = np.broadcast_to(a, (n, width))
        except ValueError:
            raise ValueError(f"{name} has {a.shape[0]} rows but the batch has {n} plants") from None
    return y


def _batch_size(plant: Params, arrays: list[ArrayLike]) -> tuple[int, bool]:
    shapes = [plant.batch_shape] + [np.shape(a)[:-1] for a in arrays]
    for s in shapes:
        if len(s) > 1:
            raise ValueError(f"batch must be one-dimensional, got leading shape {s}")
    sizes = {s[0] for s in shapes if s}
    if len(sizes) > 1:
        raise ValueError(f"batch sizes disagree: {sorted(sizes)}")
    return (sizes.pop(), True) if sizes else (1, False)


#: Called with every finished run's :class:`SimResult` (e.g. by ``mwip reproduce`` to count
#: runs for its progress display); empty by default.
RUN_END_HOOKS: list[Callable[[SimResult], None]] = []


def _steps(Ts: float, dt: float) -> int:
    if not (np.isfinite(Ts) and Ts > 0):
        raise ValueError(f"Ts must be finite and in (0, inf), got {Ts!r}")
    if not (np.isfinite(dt) and 0 < dt <= Ts):
        raise ValueError(f"dt must be in (0, Ts={Ts:g}], got {dt!r}")
    n = int(round(Ts / dt))
    if abs(n * dt - Ts) > 1e-9 * Ts:
        raise ValueError(f"dt={dt:g} must divide Ts={Ts:g} into a whole number of steps")
    return n


def _tau_block(
    disturbance: Disturbance | None, times: NDArray[np.float64], n: int
) -> NDArray[np.float64]:
    if disturbance is None:
        return np.zeros((times.size, 1, 3))
    d = np.asarray(disturbance(times), dtype=float)
    if d.shape == (times.size, 3):
        return np.ascontiguousarray(d[:, None, :])
    if d.shape == (times.size, n, 3):
        return np.ascontiguousarray(d)
    raise ValueError(
        f"disturbance must return ({times.size}, 3) or ({times.size}, {n}, 3), got {d.shape}"
    )


def simulate(
    controller: Controller,
    plant: Params = REAL,
    *,
    q0: ArrayLike = (0.0, 0.0, 0.0),
    qdot0: ArrayLike = (0.0, 0.0, 0.0),
    pos0: ArrayLike = (0.0, 0.0),
    duration: float = 10.0,
    Ts: float | None = None,
    dt: float | None = None,
    mode: Literal["sampled", "continuous"] = "sampled",
    disturbance: Disturbance | None = None,
    sensor: Sensor | None = None,
    actuator: Actuator | None = None,
    record_every: int = 1,
    seed: int | None = 0,
    progress: Callable[[int], None] | None = None,
    budget: Budget = DEFAULT_BUDGET,
    integrator: Literal["auto", "rk4", "ros2w"] = "auto",
    compiled: bool | None = None,
) -> SimResult:
    """Simulate the closed loop of ``controller`` on ``plant`` (default: the real robot).

    Parameters
    ----------
    controller : Controller
        See :mod:`mwip.laws.base`. It sees only the sensor's measurements.
    plant : Params
        Plant parameters; array-valued fields (N,) give a batch of N plants.
    q0, qdot0, pos0 : array (3,), (3,), (2,) or with a leading batch axis (N, ...)
        Initial ``[psi, theta, alpha]``, rates, and planar position.
    duration : float
        Simulated time (s); rounded to a whole number of sample periods.
    Ts : float, optional
        Sample period (s). Default: ``controller.Ts`` if set, else 5 ms.
    dt : float, optional
        Integration step (s), must divide ``Ts``. Default: by :func:`choose_integrator`,
        ``min(Ts, DEFAULT_DT_RK4)`` with RK4 on a non-stiff plant, ``min(Ts, 0.5 ms)`` with
        ROS2-W on a stiff one; continuous mode ``min(Ts, 0.5 ms)``.
    mode : "sampled" or "continuous"
        See module docstring.
    disturbance : callable, optional
        ``tau_ext(t)`` added to the plant's generalised forces (:mod:`mwip.sim.disturbance`).
    sensor : Sensor, optional
        Measurement model between plant and controller (default ideal).
    actuator : Actuator, optional
        Drive model between controller and plant (default ideal: the commanded torques are
        applied). It maps the commanded ``u`` to the torque held over the sample and may use
        the true state (it is part of the plant); the applied torque is logged as
        ``u_applied``. Sampled mode only.
    record_every : int
        Record every ``record_every``-th sample (the last sample is always kept).
    seed : int, optional
        Seed handed to the sensor (noise) so results are reproducible.
    progress : callable, optional
        Called with the number of samples done since the previous call.
    integrator : "auto", "rk4" or "ros2w"
        Sampled mode's plant integrator (:func:`choose_integrator`; docs/engine.md).
        Continuous mode always uses ROS2 with the closed loop's Jacobian.
    compiled : bool, optional
        Run the whole loop compiled (:mod:`mwip.sim.loop`): ``None`` (default) when the
        controller offers ``packed_law()`` and the loop has the ideal sensor and no actuator
        model, or a sensor with its own compiled loop (the digital twin's sensor and drive,
        :mod:`mwip.hardware.loop`); ``False`` forces the Python loop; ``True`` raises if
        it cannot be compiled.
    budget : Budget
        Bounds on the run's cost (:mod:`mwip.budget`), checked before it starts; a run above
        them raises :class:`mwip.budget.BudgetError` (a ``ValueError``).

    Bad arguments raise ``TypeError`` (wrong kind) or ``ValueError`` (out of range) naming
    the argument, before any work is done.
    """
    for name, value, allowed in (("mode", mode, ("sampled", "continuous")),
                                 ("integrator", integrator, ("auto", "rk4", "ros2w"))):  # fmt: skip
        if not isinstance(value, str) or value not in allowed:
            shown = repr(value) if isinstance(value, str) else type(value).__name__
            raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {shown}")
    if compiled is not None and not isinstance(compiled, bool | np.bool_):
        raise TypeError(f"compiled must be True, False or None, got {type(compiled).__name__}")
    if disturbance is not None and not callable(disturbance):
        raise TypeError(f"disturbance must be callable (t -> (K, 3) torques) or None, got "
                        f"{type(disturbance).__name__}")  # fmt: skip
    for name, part, needs in (("sensor", sensor, ("reset",)), ("actuator", actuator, ("reset",))):
        if part is not None and not (callable(part) and all(hasattr(part, m) for m in needs)):
            raise TypeError(f"{name} must be a mwip {name} (callable with reset()) or None, "
                            f"got {type(part).__name__}")  # fmt: skip
    if not isinstance(plant, Params):
        raise TypeError(f"plant must be a mwip.params.Params, got {type(plant).__name__}")
    if not callable(controller) or not hasattr(controller, "reset"):
        raise TypeError(
            f"controller must be a mwip controller (callable with reset()), got "
            f"{type(controller).__name__}"
        )
    if not isinstance(budget, Budget):
        raise TypeError(f"budget must be a mwip.budget.Budget, got {type(budget).__name__}")
    duration = real("duration", duration, 0.0)
    if Ts is not None:
        Ts = real("Ts", Ts, 0.0)
    if dt is not None:
        dt = real("dt", dt, 0.0)
    record_every = integer("record_every", record_every, 1, 2**62)
    if seed is not None:
        seed = integer("seed", seed, 0, 2**63 - 1)
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable, got {type(progress).__name__}")
    ctrl_ts = getattr(controller, "Ts", None)
    if Ts is None:
        Ts = ctrl_ts if ctrl_ts is not None else DEFAULT_TS
    elif ctrl_ts is not None and mode == "sampled" and abs(ctrl_ts - Ts) > 1e-12:
        raise ValueError(f"Ts={Ts:g} differs from the controller's design period {ctrl_ts:g}")
    if not (np.isfinite(Ts) and Ts > 0):
        raise ValueError(f"Ts must be finite and in (0, inf), got {Ts!r}")
    coef = np.ascontiguousarray(coefficients(plant).reshape(-1, 10))
    if mode == "continuous":
        method = ROS2W
        if dt is None:
            dt = min(Ts, DEFAULT_DT)
            if abs(round(Ts / dt) * dt - Ts) > 1e-9 * Ts:
                dt = Ts / np.ceil(Ts / dt)
    else:
        method, dt = choose_integrator(coef, Ts, dt, integrator)
    n_sub = _steps(Ts, dt)
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be finite and in (0, inf), got {duration!r}")
    if int(record_every) != record_every or record_every < 1:
        raise ValueError(f"record_every must be an integer >= 1, got {record_every!r}")
    q0, qdot0, pos0 = (finite_array(k, v) for k, v in (("q0", q0), ("qdot0", qdot0),
                                                         ("pos0", pos0)))  # fmt: skip
    n, batched = _batch_size(plant, [q0, qdot0, pos0])
    budget.check(estimate(duration, Ts, dt, n, record_every, mode), "simulate")
    n_samples = max(int(round(duration / Ts)), 1)
    duration = n_samples * Ts

    y = initial_state(n, q0, qdot0, pos0)
    r = np.broadcast_to(np.asarray(plant.r, dtype=float), (n,)).copy()
    sensor = IdealSensor() if sensor is None else sensor
    sensor.reset(n, seed)
    if actuator is not None:
        actuator.reset(n, seed)

    settings: dict[str, Any] = {
        "mode": mode, "Ts": Ts, "dt": dt, "duration": duration, "integrator": METHOD_NAMES[method],
        "record_every": int(record_every), "seed": seed,
    }  # fmt: skip
    if mode == "continuous":
        if not getattr(controller, "static", False):
            raise ValueError("mode='continuous' needs a static controller (controller.static)")
        if not isinstance(sensor, IdealSensor) or actuator is not None:
            raise ValueError("mode='continuous' supports only the ideal sensor and actuator")
        return _simulate_continuous(
            controller, coef, r, y, n_samples, n_sub, Ts, dt, disturbance, sensor,
            record_every, batched, settings, progress,
        )  # fmt: skip

    # recorded sample indices as an array (a list of 25,000 ints costs ~1 ms to build and convert)
    rec_idx = np.arange(0, n_samples + 1, int(record_every), dtype=np.int64)
    if rec_idx[-1] != n_samples:
        rec_idx = np.append(rec_idx, np.int64(n_samples))
    n_rec = rec_idx.size
    t_rec = rec_idx.astype(float) * Ts
    states = np.full((n, n_rec, 8), np.nan)
    us = np.full((n, n_rec, 2), np.nan)
    logs: dict[str, NDArray[np.float64]] = {}
    status = np.zeros(n, dtype=np.int64)
    t_end = np.full(n, duration)
    # the disturbance is sampled at the step boundaries (ROS2-W) or half steps (RK4)
    n_pts, spacing = (n_sub + 1, dt) if method == ROS2W else (2 * n_sub + 1, 0.5 * dt)
    sub_times: NDArray[np.float64] = np.arange(n_pts, dtype=np.float64) * spacing

    meas = sensor(0.0, y)
    controller.reset(meas)
    own = _own_loop(sensor, actuator, n, n_samples, compiled)
    law = _compiled_law(controller, sensor, actuator, compiled, own is not None)
    if law is not None and own is not None:
        settings["compiled"] = True
        _run_own(own, law, meas.y, y, coef, *_tau_chunks(disturbance, Ts, sub_times, n),
                 method, dt, n_sub, Ts, rec_idx, states, us, logs, status, t_end)  # fmt: skip
        if progress is not None:
            progress(n_samples)
        return _finish(t_rec, states, us, logs, status, t_end, y, r, batched, settings)
    if law is not None:
        tau_all = _tau_all(disturbance, n_samples, Ts, sub_times, n)
        if tau_all is not None:
            settings["compiled"] = True
            _run_compiled(law, y, coef, tau_all, method, dt, n_sub, n_samples, Ts, rec_idx,
                          states, us, logs, status, t_end, n_rec)  # fmt: skip
            if progress is not None:
                progress(n_samples)
            return _finish(t_rec, states, us, logs, status, t_end, y, r, batched, settings)
        if compiled:
            raise ValueError("compiled=True: the disturbance is too large to tabulate")
    settings["compiled"] = False
    from mwip.sim.kernel import advance_batch  # Numba: loaded by the runs that use it

    rec_list = rec_idx.tolist()
    get_log = getattr(controller, "log", None)
    no_tau = np.zeros((sub_times.size, 1, 3))
    row = 0
    running = n
    for k in range(n_samples + 1):
        t = k * Ts
        if k > 0:
            meas = sensor(t, y)
        u = np.asarray(controller(t, meas), dtype=float)
        if u.shape != (n, 2):
            raise ValueError(f"controller returned u of shape {u.shape}, expected ({n}, 2)")
        if actuator is not None:
            u_applied = np.asarray(actuator(t, u, y), dtype=float)
        if row < n_rec and rec_list[row] == k:
            states[:, row] = y
            us[:, row] = u
            log = dict(get_log()) if get_log is not None else {}
            if actuator is not None:
                log["u_applied"] = u_applied
            for name, val in log.items():
                arr = np.asarray(val, dtype=float).reshape(n, -1)
                if name not in logs:
                    logs[name] = np.full((n, n_rec, arr.shape[1]), np.nan)
                logs[name][:, row] = arr
            row += 1
        if k == n_samples or running == 0:  # a stop at a sample instant is recorded there
            break
        tau = no_tau if disturbance is None else _tau_block(disturbance, t + sub_times, n)
        u_hold = u if actuator is None else u_applied
        running = advance_batch(
            y, np.ascontiguousarray(u_hold), tau, coef, dt, n_sub, status, t, t_end, method
        )
        if progress is not None:
            progress(1)
    return _finish(t_rec, states, us, logs, status, t_end, y, r, batched, settings)


def _own_loop(
    sensor: Sensor, actuator: Actuator | None, n: int, n_samples: int, compiled: bool | None
) -> Any:
    """The sensor's own compiled loop for this run, or ``None``: a sensor (with its actuator)
    may offer ``compiled_loop(actuator, n, n_samples)`` returning a callable that runs the
    packed law with them in compiled code (the digital twin's, :mod:`mwip.hardware.loop`, its
    element chains packed by :mod:`mwip.hardware.pack`); the engine imports no hardware."""
    if compiled is False:
        return None
    get = getattr(sensor, "compiled_loop", None)
    return get(actuator, n, n_samples) if get is not None else None


def _compiled_law(
    controller: Controller, sensor: Sensor, actuator: Actuator | None, compiled: bool | None,
    own_loop: bool = False,
) -> PackedLaw | None:  # fmt: skip
    """The controller's :class:`~mwip.laws.packing.PackedLaw` when the whole loop can run
    compiled: the plain loop, or the sensor's own (``own_loop``, :func:`_own_loop`).

    A subclass that overrides what the Python loop calls (``__call__``, ``reset``, ``log``)
    below the class that defines ``packed_law`` runs the Python loop: its compiled law
    would not be the law it runs (e.g. a user's LQR with extra logs)."""
    if compiled is False:
        return None
    get = getattr(controller, "packed_law", None)
    if get is not None and _overrides_below_packed_law(type(controller)):
        get = None
    law = get() if get is not None else None
    plain = type(sensor) is IdealSensor and actuator is None
    ok = law is not None and (plain or own_loop)
    if compiled and not ok:
        raise ValueError(
            "compiled=True needs a controller with packed_law(), and the ideal sensor and no "
            "actuator model or a sensor with its own compiled loop (the twin's)"
        )
    return law if ok else None


def _overrides_below_packed_law(cls: type) -> bool:
    owner = next((c for c in cls.__mro__ if "packed_law" in vars(c)), None)
    if owner is None:  # set on the instance: the instance says what it runs
        return False
    below = cls.__mro__[: cls.__mro__.index(owner)]
    return any(name in vars(c) for c in below for name in ("__call__", "reset", "log"))


#: Largest tabulated disturbance (numbers) for the compiled loop; beyond it the Python loop
#: samples the disturbance one sample period at a time.
_TAU_MAX = 20_000_000


def _tau_all(
    disturbance: Disturbance | None,
    n_samples: int,
    Ts: float,
    sub_times: NDArray[np.float64],
    n: int,
) -> NDArray[np.float64] | None:
    """The disturbance at every sub-step time of the run, (n_samples, S, 1 or N, 3): the same
    times ``k Ts + sub_times`` as the Python loop's; ``None`` if too large."""
    S = sub_times.size
    if disturbance is None:
        return np.zeros((1, S, 1, 3))
    probe = _tau_block(disturbance, np.array([0.0]), n)
    if n_samples * S * probe.shape[1] * 3 > _TAU_MAX:
        return None
    times = (np.arange(n_samples) * Ts)[:, None] + sub_times[None, :]
    blk = _tau_block(disturbance, times.reshape(-1), n)
    return np.ascontiguousarray(blk.reshape(n_samples, S, blk.shape[1], 3))


def _tau_chunks(
    disturbance: Disturbance | None, Ts: float, sub_times: NDArray[np.float64], n: int
) -> tuple[Callable[[int, int], NDArray[np.float64]], NDArray[np.int64]]:
    """``(tau, column)``: ``tau(k0, k1)`` the disturbance at the sub-step times of samples
    ``k0 .. k1 - 1``, (k1 - k0 or 1, S, C, 3), at the same times ``k Ts + sub_times`` as the
    Python loop's (a loop that takes the disturbance a chunk of samples at a time, whatever
    the run's length), robot ``i`` reading column ``column[i]``. A disturbance that offers
    ``columns(t)`` (K, C, 3) and ``column_of`` (N,) (a few distinct disturbances shared by the
    robots, e.g. a campaign's) is tabulated by its columns, not per robot."""
    S = sub_times.size
    zero = np.zeros((1, S, 1, 3))
    cols = getattr(disturbance, "columns", None)
    column_of = getattr(disturbance, "column_of", None)

    def times(k0: int, k1: int) -> NDArray[np.float64]:
        return ((np.arange(k0, k1) * Ts)[:, None] + sub_times[None, :]).reshape(-1)

    if disturbance is None:
        return (lambda k0, k1: zero), np.zeros(n, dtype=np.int64)
    if cols is not None and column_of is not None:
        column = np.ascontiguousarray(column_of, dtype=np.int64)
        if column.shape == (n,):

            def tau_cols(k0: int, k1: int) -> NDArray[np.float64]:
                blk = np.asarray(cols(times(k0, k1)), dtype=float)
                return np.ascontiguousarray(blk.reshape(k1 - k0, S, blk.shape[1], 3))

            return tau_cols, column

    def tau(k0: int, k1: int) -> NDArray[np.float64]:
        blk = _tau_block(disturbance, times(k0, k1), n)
        return np.ascontiguousarray(blk.reshape(k1 - k0, S, blk.shape[1], 3))

    wide = _tau_block(disturbance, np.array([0.0]), n).shape[1] > 1
    return tau, (np.arange(n, dtype=np.int64) if wide else np.zeros(n, dtype=np.int64))


def _run_own(
    own: Any,
    law: PackedLaw,
    first: NDArray[np.float64],
    y: NDArray[np.float64],
    coef: NDArray[np.float64],
    tau: Callable[[int, int], NDArray[np.float64]],
    column: NDArray[np.int64],
    method: int,
    dt: float,
    n_sub: int,
    Ts: float,
    rec_idx: NDArray[np.int64],
    states: NDArray[np.float64],
    us: NDArray[np.float64],
    logs: dict[str, NDArray[np.float64]],
    status: NDArray[np.int64],
    t_end: NDArray[np.float64],
) -> None:
    """Run the sensor's own compiled loop (:func:`_own_loop`) from the first measurement
    ``first``, the disturbance by chunks (:func:`_tau_chunks`: ``tau``, ``column``), and
    unpack the law's log columns and the loop's own logs into ``logs``."""
    import numba

    n = y.shape[0]
    log_arr = np.full((n, rec_idx.size, law.log_width), np.nan)
    _compile_notice(own.function(), "the digital twin's loop")
    # the threads only for a threaded batch (as the plain loop): starting them for one robot
    # would start OpenMP in this process, and a process pool forked after it dies
    threaded = n >= PARALLEL_MIN
    old = (numba.set_parallel_chunksize(max(1, n // (16 * numba.get_num_threads())))
           if threaded else None)  # fmt: skip
    try:
        P, X = law.arrays(n)
        extra = own(first, y, coef, tau, column, method, dt, n_sub, Ts, rec_idx, law.code, P,
                    X, states, us, log_arr, status, t_end)  # fmt: skip
    finally:
        if old is not None:
            numba.set_parallel_chunksize(old)
    logs.update(law.split_logs(log_arr))
    logs.update(extra)


def _run_compiled(
    law: PackedLaw,
    y: NDArray[np.float64],
    coef: NDArray[np.float64],
    tau_all: NDArray[np.float64],
    method: int,
    dt: float,
    n_sub: int,
    n_samples: int,
    Ts: float,
    rec_idx: NDArray[np.int64],
    states: NDArray[np.float64],
    us: NDArray[np.float64],
    logs: dict[str, NDArray[np.float64]],
    status: NDArray[np.int64],
    t_end: NDArray[np.float64],
    n_rec: int,
) -> None:
    """Run :mod:`mwip.sim.loop` and unpack its log columns into ``logs``."""
    n = y.shape[0]
    log_arr = np.full((n, n_rec, law.log_width), np.nan)
    fn: Any = aot.run_function() if n < PARALLEL_MIN else None  # no Numba import (mwip.sim.aot)
    old = None
    if fn is None:
        from mwip.sim import loop

        if n >= PARALLEL_MIN:
            import numba

            # dynamic scheduling in chunks of whole robots: a thread whose core is busy with
            # another process takes fewer chunks instead of holding the others at the end
            fn = loop.run_parallel
            old = numba.set_parallel_chunksize(max(1, n // (16 * numba.get_num_threads())))
        else:
            fn = loop.run
        _compile_notice(fn, "the threaded batch loop" if n >= PARALLEL_MIN else "the loop")
    try:
        _call(fn, law, y, coef, tau_all, method, dt, n_sub, n_samples, Ts, rec_idx, states, us,
              log_arr, status, t_end)  # fmt: skip
    finally:
        if old is not None:
            numba.set_parallel_chunksize(old)
    logs.update(law.split_logs(log_arr))


def _compile_notice(fn: Any, what: str) -> None:
    """Say so before Numba compiles ``fn`` (a :mod:`mwip.sim.loop` dispatcher): not compiled in
    this process and no entry in Numba's on-disk cache (:mod:`mwip.jit_cache`) -- the first
    run after installing or editing mwip (:mod:`mwip.notice`)."""
    from mwip.notice import once

    try:
        if fn.signatures or fn._cache._cache_file._load_index():
            return
    except Exception:  # noqa: BLE001 - Numba internals: when unsure, say nothing
        return
    once(f"jit:{fn.__name__}", f"compiling {what} of the simulation with Numba (first use "
         "after installing or changing mwip; it happens once and is cached, minutes on a "
         "slow machine)")  # fmt: skip


def _call(fn, law, y, coef, tau_all, method, dt, n_sub, n_samples, Ts, rec_idx, states, us,  # noqa: ANN001, ANN202, PLR0913
          log_arr, status, t_end):  # fmt: skip
    """``fn`` (:func:`mwip.sim.loop.run` or ``run_parallel``) with the law's packed vectors
    (fresh writable C copies, :meth:`~mwip.laws.packing.PackedLaw.arrays`): one compiled
    signature for every law."""
    P, X = law.arrays(y.shape[0])
    fn(y, coef, tau_all, method, dt, n_sub, n_samples, Ts, rec_idx, np.int64(law.code), P, X,
       states, us, log_arr, status, t_end)  # fmt: skip


def _finish(
    t_rec: NDArray[np.float64],
    states: NDArray[np.float64],
    us: NDArray[np.float64],
    logs: dict[str, NDArray[np.float64]],
    status: NDArray[np.int64],
    t_end: NDArray[np.float64],
    y: NDArray[np.float64],
    r: NDArray[np.float64],
    batched: bool,
    settings: dict[str, Any],
) -> SimResult:
    after = t_rec[None, :] > t_end[:, None] + 1e-12
    states[after] = np.nan
    us[after] = np.nan
    for arr in logs.values():
        arr[after] = np.nan
    # squeeze scalar logs to (N, K)
    logs = {k: (v[..., 0] if v.shape[-1] == 1 else v) for k, v in logs.items()}
    res = SimResult(
        t=t_rec, states=states, inputs=us, status=np.array([STATUS_NAMES[s] for s in status]),
        t_end=t_end, final_state=y.copy(), r=r, batched=batched, logs=logs, settings=settings,
    )  # fmt: skip
    if not batched:
        keep = res.valid()[0]
        res = res.plant(0) if not keep.all() else res
    for hook in RUN_END_HOOKS:
        hook(res)
    return res


# ---------------------------------------------------------------------------------------------
# continuous mode: static law inside the right-hand side, ROS2 with the full Jacobian
# ---------------------------------------------------------------------------------------------
def _plant_rhs(coef: NDArray[np.float64], y: NDArray[np.float64], u: NDArray[np.float64],
               e: NDArray[np.float64]) -> NDArray[np.float64]:  # fmt: skip
    """``y'`` of the plant for states (M, 8), inputs (M, 2), disturbances (M, 3) (compiled)."""
    from mwip.sim.kernel import rhs_batch

    f64 = np.float64
    return rhs_batch(
        np.ascontiguousarray(coef, dtype=f64), np.ascontiguousarray(y, dtype=f64),
        np.ascontiguousarray(u, dtype=f64), np.ascontiguousarray(e, dtype=f64),
        np.empty((y.shape[0], 8)),
    )  # fmt: skip


def _simulate_continuous(
    controller: Controller,
    coef: NDArray[np.float64],
    r: NDArray[np.float64],
    y: NDArray[np.float64],
    n_samples: int,
    n_sub: int,
    Ts: float,
    dt: float,
    disturbance: Disturbance | None,
    sensor: Sensor,
    record_every: int,
    batched: bool,
    settings: dict[str, Any],
    progress: Callable[[int], None] | None,
) -> SimResult:
    from mwip.sim.kernel import ros2_stage, ros2_update

    n = y.shape[0]
    coef_n = np.broadcast_to(coef, (n, 10))
    coef_j = np.tile(coef_n, (9, 1))  # base + 8 perturbations

    def law(t: float, yy: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(controller(t, sensor(t, yy)), dtype=float)

    zeros = {n: np.zeros((n, 3)), 9 * n: np.zeros((9 * n, 3))}

    def tau_at(t: float, m: int) -> NDArray[np.float64]:
        if disturbance is None:
            return zeros[m]
        blk = _tau_block(disturbance, np.array([t]), n)[0]
        return (
            np.broadcast_to(blk, (n, 3))
            if m == n
            else np.tile(np.broadcast_to(blk, (n, 3)), (9, 1))
        )

    def closed(t: float, yy: NDArray[np.float64], cf: NDArray[np.float64]) -> NDArray[np.float64]:
        return _plant_rhs(cf, yy, law(t, yy), tau_at(t, yy.shape[0]))

    eye = np.eye(8)
    zero8 = np.zeros((n, 8))
    status = np.zeros(n, dtype=np.int64)
    t_end = np.full(n, n_samples * Ts)
    rec_idx = list(range(0, n_samples + 1, int(record_every)))
    if rec_idx[-1] != n_samples:
        rec_idx.append(n_samples)
    t_rec = np.array(rec_idx, dtype=float) * Ts
    states = np.full((n, len(rec_idx), 8), np.nan)
    us = np.full((n, len(rec_idx), 2), np.nan)
    controller.reset(sensor(0.0, y))
    row = 0
    for k in range(n_samples + 1):
        t = k * Ts
        if row < len(rec_idx) and rec_idx[row] == k:
            states[:, row] = y
            us[:, row] = law(t, y)
            row += 1
        if k == n_samples:
            break
        # ROS2 is a W-method (second order for any W): the finite-difference Jacobian of the
        # closed loop, all plants and columns at once, is refreshed once per sample period
        delta = 1e-7 * np.maximum(np.abs(y), 1.0)  # (n, 8)
        pert = np.concatenate([y] + [y + delta[:, [c]] * eye[c] for c in range(8)], axis=0)
        fx = closed(t, pert, coef_j).reshape(9, n, 8)
        J = np.stack([(fx[c + 1] - fx[0]) / delta[:, [c]] for c in range(8)], axis=-1)
        Winv = np.ascontiguousarray(np.linalg.inv(eye - GAMMA * dt * J))
        running = n
        for j in range(n_sub):
            tj = t + j * dt
            f0 = fx[0] if j == 0 else closed(tj, y, coef_n)
            k1 = ros2_stage(Winv, np.ascontiguousarray(f0), zero8, np.empty((n, 8)))
            f1 = closed(tj + dt, y + dt * k1, coef_n)
            k2 = ros2_stage(Winv, f1, k1, np.empty((n, 8)))
            running = ros2_update(y, k1, k2, dt, status, tj + dt, t_end)
            if running == 0:
                break
        if progress is not None:
            progress(1)
        if np.all(status != OK):
            break
    return _finish(t_rec, states, us, {}, status, t_end, y, r, batched, settings)
