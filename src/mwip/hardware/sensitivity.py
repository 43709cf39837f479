"""Sensitivity of the twin's assumed geometry: the Case 2 payload, the Case 3 stick, the gear.

The book states Case 2 only as "a pan ... the height of the MWIP system is increased by 10 cm
and the weight is increased by 0.5 kg" (Sec. 6.2.2, Fig. 6.2) and Case 3 as "a small stick";
the gearbox is not named. :meth:`mwip.params.Params.with_payload` and
:class:`mwip.hardware.obstacle.StickObstacle` state the assumed geometry; the functions here
vary it and return the numbers that carry it into the dynamics (docs/twin_model.md):

- :func:`payload_sensitivity`: for payload mass 0.1-0.5 kg, rod height and body height, the
  body mass, centre-of-mass height ``l``, pitch inertia ``Iby``, gravity term ``Gb = mb g l``
  against the nominal model's, and the open-loop unstable pitch pole of the linearised
  (2.32) (the speed the controller must beat);
- :func:`stick_sensitivity`: for stick heights, the climb angle ``arccos(1 - h/r)``, pulse
  length at the set speed, resisting torque ``m g h / dpsi`` and its impulse;
- :func:`gear_sensitivity`: for gear ratios, the reflected inertia, the pitch input gain of
  the twin's plant against the nominal model's, the back-EMF damping, wheel stall torque and
  no-load speed;
- :func:`payload_closed_loop`, :func:`stick_closed_loop`: a controller on the twin for each
  payload mass / stick height (one batched run each).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.identified import default_twin
from mwip.hardware.motor import DriveSpec
from mwip.hardware.obstacle import StickObstacle
from mwip.hardware.twin import Twin, run_on_twin
from mwip.metrics import rms
from mwip.params import NOMINAL, REAL, Params, stack_params
from mwip.sim.result import SimResult

__all__ = [
    "pitch_pole",
    "input_gains",
    "payload_sensitivity",
    "stick_sensitivity",
    "gear_sensitivity",
    "payload_closed_loop",
    "stick_closed_loop",
    "sensitivity_tables",
    "tables_markdown",
]


def _planar(p: Params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    M = np.array([[p.m11, p.m12], [p.m12, p.m22]], dtype=float)
    D = np.array([[2 * p.Dw + 2 * p.Db, -2 * p.Db], [-2 * p.Db, 2 * p.Db]], dtype=float)
    K = np.array([[0.0, 0.0], [0.0, p.Gb]], dtype=float)
    return M, D, K


def pitch_pole(p: Params) -> float:
    """Unstable open-loop pole (1/s) of (2.32) linearised upright in ``(psi, theta)``:
    ``M q'' + D q' = [0, Gb theta]`` (the yaw row decouples)."""
    M, D, K = _planar(p)
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [Mi @ K, -Mi @ D]])
    return float(np.max(np.linalg.eigvals(A).real))


def input_gains(p: Params) -> tuple[float, float]:
    """``(psi''/u_A, theta''/u_A)`` upright at rest: ``M^-1 [1, -1]`` (rad/s^2 per N m)."""
    M, _, _ = _planar(p)
    g = np.linalg.solve(M, np.array([1.0, -1.0]))
    return float(g[0]), float(g[1])


def payload_sensitivity(
    masses: Sequence[float] = (0.1, 0.2, 0.3, 0.4, 0.5),
    heights: Sequence[float] = (0.05, 0.1, 0.15),
    body_heights: Sequence[float | None] = (None,),
    base: Params = REAL,
    nominal: Params = NOMINAL,
) -> list[dict[str, Any]]:
    """One row per (mass, rod height, body height): the Case 2 plant's ``mb, l, Iby, Gb``,
    ``Gb / Gb_nominal`` and the pitch pole, for :meth:`Params.with_payload` (body height
    ``None``: the assumed ``2 l``)."""
    rows = []
    for bh in body_heights:
        for h in heights:
            for m in masses:
                p = base.with_payload(mass=m, height=h, body_height=bh)
                rows.append({
                    "mass": float(m), "rod_height": float(h),
                    "body_height": float(2 * base.l if bh is None else bh),
                    "mb": float(p.mb), "l": float(p.l), "Iby": float(p.Iby), "Gb": float(p.Gb),
                    "Gb_over_nominal": float(p.Gb / nominal.Gb),
                    "pitch_pole": pitch_pole(p),
                })  # fmt: skip
    return rows


def stick_sensitivity(
    heights: Sequence[float] = (0.005, 0.01, 0.015, 0.02),
    plant: Params | None = None,
    speed: float = -7.0,
) -> list[dict[str, float]]:
    """One row per stick height (m): climb angle (rad), pulse length (s) at ``speed``,
    resisting torque (N m) and its impulse ``T dpsi/|speed|`` (N m s) for the Case 2 robot."""
    p = REAL.with_payload() if plant is None else plant
    mass = float(p.mb + 2 * p.mw)
    rows = []
    for h in heights:
        s = StickObstacle(height=h, speed=speed, mass=mass, r=float(p.r))
        rows.append({"height": float(h), "climb_angle": s.climb_angle, "duration": s.duration,
                     "torque": s.torque, "impulse": s.torque * s.duration,
                     "work": s.torque * s.climb_angle})  # fmt: skip
    return rows


def gear_sensitivity(
    ratios: Sequence[float] = (8.0, 11.0, 15.0, 23.0, 33.0, 51.0),
    twin: Twin | None = None,
    base: Params = REAL,
    nominal: Params = NOMINAL,
) -> list[dict[str, float]]:
    """One row per gear ratio ``N``: ``N^2 J`` against ``Iwa``, the pitch input gain
    ``theta''/u_A`` of the twin's plant (reflected inertia on) over the nominal model's, the
    pitch pole, the back-EMF damping ``eta N^2 k_t k_e / R``, the wheel stall torque and the
    wheel no-load speed."""
    tw = default_twin() if twin is None else twin
    g_nom = input_gains(nominal)[1]
    rows = []
    for n in ratios:
        drive: DriveSpec = replace(tw.drive, gear_ratio=float(n))
        t2 = replace(tw, drive=drive, elements=frozenset({"inertia"}))
        p = t2.plant(base)
        m = tw.motor
        rows.append({
            "gear_ratio": float(n),
            "reflected_over_Iwa": float(n * n * m.rotor_inertia / base.Iwa),
            "pitch_gain_over_nominal": input_gains(p)[1] / g_nom,
            "pitch_pole": pitch_pole(p),
            "emf_damping": drive.emf_damping(m),
            "wheel_stall_torque": float(n * drive.gear_efficiency * m.stall_torque),
            "wheel_no_load_speed": float(m.no_load_speed_rpm * 2 * np.pi / 60 / n),
        })  # fmt: skip
    return rows


def _closed_rows(
    res: SimResult, values: Sequence[float], key: str, window: tuple[float, float], q1d: float
) -> list[dict[str, float]]:
    rows = []
    meas = res.series().get("y_meas")
    for i, v in enumerate(values):
        ok = res.status[i] == "ok"
        nan = float("nan")
        rows.append({
            key: float(v),
            "rms_theta": float(rms(res.t, res.states[i, :, 1], window)) if ok else nan,
            "rms_theta_meas": float(rms(res.t, meas[i, :, 1], window))
            if ok and meas is not None else nan,
            "rms_speed_err": float(rms(res.t, res.states[i, :, 3] - q1d, window)) if ok else nan,
            "t_end": float(res.t_end[i]),
        })  # fmt: skip
    return rows


def payload_closed_loop(
    factory: Callable[[], Any],
    masses: Sequence[float] = (0.1, 0.2, 0.3, 0.4, 0.5),
    *,
    twin: Twin | None = None,
    height: float = 0.1,
    base: Params = REAL,
    window: tuple[float, float] = (2.0, 10.0),
    q1d_dot: float = 0.0,
    **run_kwargs: Any,
) -> list[dict[str, float]]:
    """RMS (6.3) of ``factory()`` (a batch-capable controller) on the twin with each payload
    mass on rods of ``height`` (Case 2 geometry, :meth:`Params.with_payload`): one batched
    run; ``run_kwargs`` go to :func:`mwip.hardware.twin.run_on_twin` (``q0``, ``duration``,
    ``seed``, ...); every row sees the IMU noise of a single run (``common_noise``)."""
    plant = stack_params([base.with_payload(mass=m, height=height) for m in masses])
    run_kwargs.setdefault("common_noise", True)
    res = run_on_twin(factory(), 2, twin=twin, plant=plant, **run_kwargs)
    return _closed_rows(res, masses, "mass", window, q1d_dot)


class _Sticks:
    """A batch of sticks, one per robot: ``tau_ext(t) -> (K, N, 3)``."""

    def __init__(self, sticks: Sequence[StickObstacle]) -> None:
        self.sticks = list(sticks)

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.stack([s(t) for s in self.sticks], axis=-2)


def stick_closed_loop(
    factory: Callable[[], Any],
    heights: Sequence[float] = (0.005, 0.01, 0.015, 0.02),
    *,
    twin: Twin | None = None,
    plant: Params | None = None,
    speed: float = -7.0,
    start: float = 6.0,
    window: tuple[float, float] = (2.0, 10.0),
    **run_kwargs: Any,
) -> list[dict[str, float]]:
    """RMS (6.3) of ``factory()`` on the twin (Case 2 plant unless ``plant``) crossing a stick
    of each height at ``start`` while running at ``speed``: one batched run (the controller
    should track ``speed``)."""
    p = REAL.with_payload() if plant is None else plant
    mass = float(p.mb + 2 * p.mw)
    sticks = [StickObstacle(height=h, start=start, speed=speed, mass=mass, r=float(p.r))
              for h in heights]  # fmt: skip
    batch = stack_params([p] * len(heights))
    run_kwargs.setdefault("common_noise", True)
    res = run_on_twin(factory(), 2, twin=twin, plant=batch, disturbance=_Sticks(sticks),
                      **run_kwargs)  # fmt: skip
    return _closed_rows(res, heights, "height", window, speed)


def sensitivity_tables(robot: Any = None) -> dict[str, list[dict[str, Any]]]:
    """All three tables with their default ranges, for ``robot`` (a
    :class:`mwip.robot.Robot`; default: the default robot): its body, payload and twin."""
    from mwip.robot import robot_or_default

    r = robot_or_default(robot)
    loaded = r.case_plant(2)
    return {"payload": payload_sensitivity(base=r.body, nominal=r.design),
            "stick": stick_sensitivity(plant=loaded),
            "gear": gear_sensitivity(twin=r.twin, base=r.body, nominal=r.design)}  # fmt: skip


def tables_markdown(tables: dict[str, list[dict[str, Any]]]) -> str:
    """The tables as markdown (4 significant digits)."""
    out = []
    for name, rows in tables.items():
        if not rows:
            continue
        keys = list(rows[0])
        out.append(f"{name}\n")
        out.append("| " + " | ".join(keys) + " |")
        out.append("|" + "---|" * len(keys))
        for r in rows:
            out.append("| " + " | ".join(f"{r[k]:.4g}" for k in keys) + " |")
        out.append("")
    return "\n".join(out)
