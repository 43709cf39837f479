"""The digital twin of the Chapter 6 robot: plant + firmware + drive train + sensors.

:class:`Twin` is the hardware part of a robot (:mod:`mwip.robot`: the robot file's drive,
firmware, sensors, payload and the prior of their unknowns); every physical effect is an
element switch (:mod:`mwip.hardware.elements`) that can be turned off, and ``Twin.ideal()``
turns all off (the plain simulation, bit for bit). The pieces:

- the plant (:meth:`Twin.plant`): the case's parameters plus the rotor inertia reflected
  through the gearbox and, for a voltage drive, the back-EMF damping on ``Db``
  (:mod:`mwip.hardware.drivetrain`);
- the sensor chain (:class:`TwinSensor`, the sensor protocol of :mod:`mwip.sim.sensors`):
  what the LM3S2965 board measures and computes: the IMU (:mod:`mwip.hardware.imu`), the
  firmware's pitch estimate (:mod:`mwip.hardware.fusion`), the encoders and odometry
  (:mod:`mwip.hardware.encoder`);
- the drive chain (:class:`TwinActuator`, the actuator protocol): the firmware's delay and
  torque-to-duty map (:mod:`mwip.hardware.delay`, :mod:`mwip.hardware.firmware`), the RE25
  motors and PWM driver (:mod:`mwip.hardware.motor`), gearbox Coulomb friction
  (:mod:`mwip.hardware.friction`) and backlash (:mod:`mwip.hardware.backlash`).

Each element has one compiled implementation (:mod:`mwip.hardware.element`). A controller with
a packed law runs with the whole loop compiled (:mod:`mwip.hardware.loop`); any other
controller runs in the engine's Python loop, whose :class:`TwinSensor` and
:class:`TwinActuator` step the same compiled chains for the batch at each sample.

:func:`run_on_twin` runs any mwip controller on it unchanged, for the book's uncertainty
cases (:data:`CASES`):

- case 1: the real robot (Table 6.1);
- case 2: with the 0.5 kg pan on 0.1 m rods (:meth:`mwip.params.Params.with_payload`);
- case 3: case 2 crossing a stick at about 6 s (:class:`mwip.hardware.obstacle.StickObstacle`).

With ``rows`` it runs one controller on a batch of twins that differ only in their elements
(the ablation of :mod:`mwip.hardware.ablation`); with ``values`` on a batch of twins that
differ in their unknown values (:mod:`mwip.hardware.prior`: row ``i`` is
``twin.with_values({k: values[k][i]})``, every element taking its parameters per row); with
``common_noise`` (the default for both) every row sees the IMU noise of a single run with the
same seed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Controller, Measurement
from mwip.hardware.drivetrain import GearboxSpec, derive_plant, relative_mobility
from mwip.hardware.element import PackContext
from mwip.hardware.elements import (
    DRIVE_ELEMENTS,
    ELEMENTS,
    PLANT_ELEMENTS,
    SENSOR_ELEMENTS,
    check_elements,
    element_mask,
)
from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.firmware import FirmwareSpec
from mwip.hardware.identified import default_twin
from mwip.hardware.imu import ImuNoise
from mwip.hardware.motor import RE25, DriveSpec, MotorData
from mwip.hardware.obstacle import StickObstacle, StickRows, StickSpec
from mwip.hardware.pack import Chain, pack_chain
from mwip.hardware.payload import PayloadSpec
from mwip.hardware.prior import current_name
from mwip.hardware.registry import DRIVE_CHAIN, SENSOR_CHAIN
from mwip.params import REAL, Params
from mwip.sim.disturbance import Disturbance, Sum
from mwip.sim.engine import simulate
from mwip.sim.result import SimResult

if TYPE_CHECKING:
    from mwip.hardware.prior import Prior

__all__ = [
    "Twin", "TwinSensor", "TwinActuator", "case_plant", "run_on_twin", "CASES", "stick_for",
    "NoiseTable",
]  # fmt: skip

CASES = {1: "real robot (Table 6.1)", 2: "with payload (0.5 kg on 0.1 m rods)",
         3: "with payload, crossing a stick at ~6 s"}  # fmt: skip

_IDX = {e: i for i, e in enumerate(ELEMENTS)}


def _declared_prior() -> Prior:
    from mwip.hardware.prior import PRIOR

    return PRIOR


@dataclass(frozen=True)
class Twin:
    """The hardware of a robot (defaults and their sources: docs/twin_model.md).

    ``motor``, ``drive`` (gearbox ratio and efficiency, battery, PWM driver), ``gearbox``
    (friction, backlash), ``firmware`` (sample period, delay, torque gain, back-EMF
    compensation, gyro zeroing, fusion), ``imu``, ``encoder``; ``dt`` the plant's integration
    step; ``elements`` the physical effects switched on
    (:data:`mwip.hardware.elements.ELEMENTS`, all by default); ``ideal_sensors`` /
    ``ideal_actuator`` switch off all sensor / all drive-train elements (the twin then
    reproduces the plain simulation exactly). ``payload`` is the Case 2/3 pan, ``stick`` the
    Case 3 stick; ``prior`` the ranges of the unknown values (:mod:`mwip.hardware.prior`;
    :meth:`values`, :meth:`with_values`).
    """

    imu: ImuNoise = field(default_factory=ImuNoise)
    encoder: EncoderSpec = field(default_factory=EncoderSpec)
    motor: MotorData = RE25
    drive: DriveSpec = field(default_factory=DriveSpec)
    firmware: FirmwareSpec = field(default_factory=FirmwareSpec)
    dt: float = 0.0005
    ideal_sensors: bool = False
    ideal_actuator: bool = False
    gearbox: GearboxSpec = field(default_factory=GearboxSpec)
    elements: frozenset[str] = frozenset(ELEMENTS)
    payload: PayloadSpec = field(default_factory=PayloadSpec)
    stick: StickSpec = field(default_factory=StickSpec)
    prior: Prior = field(default_factory=_declared_prior)

    def __post_init__(self) -> None:
        object.__setattr__(self, "elements", check_elements(self.elements))
        if not (np.isfinite(self.dt) and 0 < self.dt <= self.Ts):
            raise ValueError(f"'dt' must be finite and in (0, Ts], got {self.dt!r}")
        n = round(self.Ts / self.dt)
        if abs(n * self.dt - self.Ts) > 1e-9 * self.Ts:
            raise ValueError(f"'dt' ({self.dt!r}) must divide the sample period "
                             f"firmware.Ts ({self.Ts!r})")  # fmt: skip

    @property
    def Ts(self) -> float:
        """The sample period: the firmware's (``firmware.Ts``)."""
        return self.firmware.Ts

    def values(self) -> dict[str, float]:
        """The twin's value of every unknown of :attr:`prior` (dotted names)."""
        return {name: _get(self, name) for name in self.prior.names}

    def with_values(self, mapping: Mapping[str, float]) -> Twin:
        """This twin with the unknowns ``mapping`` (dotted names) replaced; an unknown name or
        a value outside :attr:`prior` is a one-line ``ValueError`` naming it."""
        out: Twin = self
        for raw_name, raw in mapping.items():
            name = current_name(raw_name)
            if name not in self.prior.names:
                raise ValueError(
                    f"with_values: unknown name {raw_name!r}; allowed: "
                    f"{', '.join(self.prior.names)}"
                )
            u = self.prior[name]
            v = float(raw)
            if not (np.isfinite(v) and u.low <= v <= u.high):
                raise ValueError(
                    f"with_values: {name!r} = {v!r} is outside the prior [{u.low:g}, {u.high:g}]"
                    f" (prior.{name})"
                )
            try:
                out = _set(out, name.split("."), v)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"with_values: {exc}") from None
        return out

    def row_values(self, values: Mapping[str, ArrayLike]) -> tuple[dict[str, Any], int]:
        """Validated per-row values of a batch of twins: ``({name: value}, N)`` with every
        unknown of :attr:`prior`: a float (this twin's) or, for those in ``values``, an (N,)
        array (one-line ``ValueError`` naming the key for a wrong shape, a name not in the
        prior or a value outside it)."""
        out: dict[str, Any] = self.values()
        n: int | None = None
        for raw_name, raw in values.items():
            name = current_name(raw_name)
            if name not in self.prior.names:
                raise ValueError(
                    f"values: unknown name {raw_name!r}; allowed: {', '.join(self.prior.names)}"
                )
            a = np.asarray(raw, dtype=float)
            if a.ndim != 1 or a.size == 0:
                raise ValueError(f"values[{raw_name!r}] must be a 1-D array, got shape {a.shape}")
            if n is None:
                n = a.size
            elif a.size != n:
                raise ValueError(f"values[{raw_name!r}] has {a.size} rows, the others {n}")
            u = self.prior[name]
            bad = ~(np.isfinite(a) & (a >= u.low) & (a <= u.high))
            if bad.any():
                i = int(np.argmax(bad))
                raise ValueError(
                    f"values[{raw_name!r}][{i}] = {float(a[i])!r} is outside the prior "
                    f"[{u.low:g}, {u.high:g}] (prior.{name})"
                )
            self.with_values({name: float(a.min())})  # the elements' own limits (intervals)
            self.with_values({name: float(a.max())})
            out[name] = a.copy()
        if n is None:
            raise ValueError("values: give at least one unknown")
        return out, n

    @classmethod
    def ideal(cls, **kw: Any) -> Twin:
        """Ideal sensors and actuator: a plumbing check against :func:`mwip.sim.simulate`."""
        kw.setdefault("elements", frozenset())
        return cls(ideal_sensors=True, ideal_actuator=True, **kw)

    @property
    def active(self) -> frozenset[str]:
        """The elements in effect (``elements`` less those the ``ideal_*`` flags remove)."""
        out = set(self.elements)
        if self.ideal_sensors:
            out -= SENSOR_ELEMENTS
        if self.ideal_actuator:
            out -= DRIVE_ELEMENTS | PLANT_ELEMENTS
        return frozenset(out)

    def masks(self, rows: Iterable[Iterable[str]] | None = None) -> NDArray[np.bool_]:
        """(N, E) element mask: one row of :attr:`active`, or ``rows`` (each intersected with
        :attr:`active`)."""
        if rows is None:
            return element_mask([self.active])
        return element_mask([check_elements(r, "rows") & self.active for r in rows])

    def plant(
        self, base: Params, rows: Iterable[Iterable[str]] | None = None,
        values: Mapping[str, Any] | None = None,
    ) -> Params:  # fmt: skip
        """The plant the twin integrates for the case plant ``base``: the reflected rotor
        inertia (``inertia``), the back-EMF damping of a voltage drive (``motor``) and the
        gearbox's viscous friction (``friction``) on ``Db`` (:mod:`mwip.hardware.drivetrain`).
        One row per entry of ``rows`` (a batch), else ``base``'s own shape; ``values``: the
        per-row unknowns of :meth:`row_values` (gear ratio and viscous friction per row)."""
        m = self.masks(rows)
        col = (lambda e: m[:, _IDX[e]]) if rows is not None else (lambda e: m[0, _IDX[e]])
        v = self.values() if values is None else values
        n = v["drive.gear_ratio"]
        emf = self.drive.emf_damping(self.motor, n) if self.drive.mode == "voltage" else 0.0
        extra = col("motor") * emf + col("friction") * v["gearbox.viscous"]
        return derive_plant(base, inertia=col("inertia"), extra_db=extra, gear_ratio=n,
                            rotor_inertia=self.motor.rotor_inertia)  # fmt: skip

    def sensor(
        self, plant: Params, rows: Iterable[Iterable[str]] | None = None, *,
        common_noise: bool = False, values: Mapping[str, Any] | None = None,
        noise: NoiseTable | None = None,
    ) -> TwinSensor:  # fmt: skip
        """A fresh sensor chain for ``plant`` (the plant the twin integrates, for its wheel
        geometry: one row per robot or one for all); ``values``: the per-row unknowns of
        :meth:`row_values`; ``noise``: the variates per robot instead of the run's seed."""
        return TwinSensor(plant, self, masks=self.masks(rows), common_noise=common_noise,
                          values=values, noise=noise)  # fmt: skip

    def actuator(
        self, plant: Params, rows: Iterable[Iterable[str]] | None = None,
        values: Mapping[str, Any] | None = None, *, command: Mapping[str, Any] | None = None,
        noise: NoiseTable | None = None,
    ) -> TwinActuator:  # fmt: skip
        """A fresh drive chain for ``plant``; ``values``: the per-row unknowns of
        :meth:`row_values`; ``command``: the optional command disturbances per robot
        (:mod:`mwip.hardware.command`) with their ``noise``."""
        return TwinActuator(plant, self, masks=self.masks(rows), values=values,
                            command=command, noise=noise)  # fmt: skip


def _get(obj: Any, name: str) -> float:
    for part in name.split("."):
        obj = getattr(obj, part)
    return float(obj)


def _set(obj: Any, path: list[str], value: float) -> Any:
    """``obj`` (a frozen dataclass) with the field at ``path`` replaced."""
    if len(path) == 1:
        return replace(obj, **{path[0]: value})
    return replace(obj, **{path[0]: _set(getattr(obj, path[0]), path[1:], value)})


class NoiseTable:
    """The normal variates of a chain's elements per robot, given instead of drawn: ``table``
    (N, S, V) for ``S`` samples of ``V`` variates (sample ``k`` reads row ``k mod S``)."""

    def __init__(self, table: ArrayLike) -> None:
        self.table = np.asarray(table, dtype=float)
        if self.table.ndim != 3:
            raise ValueError(f"NoiseTable: table must be (N, samples, variates), got shape "
                             f"{self.table.shape}")  # fmt: skip

    def draw(self, k0: int, k1: int, width: int) -> NDArray[np.float64]:
        """Samples ``k0 .. k1 - 1``: (k1 - k0, width, N)."""
        S = self.table.shape[1]
        if self.table.shape[2] != width:
            raise ValueError(f"NoiseTable: {self.table.shape[2]} variates per sample, the "
                             f"chain draws {width}")  # fmt: skip
        idx = np.arange(k0, k1) % S
        return np.ascontiguousarray(self.table[:, idx, :].transpose(1, 2, 0))


class _Generator:
    """The run's own variates: NumPy's generator seeded by the run's seed, one column per
    robot or one for all (``common``), drawn in sample order."""

    def __init__(self, seed: int | None, columns: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.columns = columns

    def draw(self, k0: int, k1: int, width: int) -> NDArray[np.float64]:
        if width == 0 or k1 <= k0:
            return np.zeros((max(k1 - k0, 1), width, self.columns))
        return np.ascontiguousarray(self.rng.standard_normal((k1 - k0, width, self.columns)))


class _Chained:
    """What the sensor and the actuator share: a packed chain, its state, its noise and the
    sample it is at."""

    chain: Chain
    X: NDArray[np.float64]
    k: int

    def _pack(self, chain: Any, plant: Params, twin: Twin, masks: NDArray[np.bool_],
              values: Mapping[str, Any] | None, n: int,
              extra: Mapping[str, Any]) -> None:  # fmt: skip
        v = twin.values() if values is None else values
        ctx = PackContext(twin=twin, plant=plant, values=v, masks=masks, n=n, extra=extra)
        self.chain = pack_chain(chain, ctx)
        self.X = self.chain.fresh_state()
        self.k = 0


class TwinSensor(_Chained):
    """Sensor protocol: the twin's sensor chain (IMU, the firmware's pitch estimate,
    encoders and odometry) for a batch, per robot as its element switches say (``encoder``,
    ``fusion``, ``accel_motion``, ``imu_noise``, ``imu_bias``): a robot without ``encoder``
    gets the true ``psi, alpha``, rates and position, one without ``fusion`` the true
    ``theta, theta'``. ``last`` holds the chain's logs of the last call (``imu_theta_acc``,
    ``imu_gyro``, ``imu_gyro_bias``). In the compiled loop, ``record_measurement`` also records
    the measurement as the log ``y_meas`` and ``record_logs`` the elements' logs (both set by
    :func:`run_on_twin`)."""

    record_measurement: bool = False
    record_logs: bool = False

    def __init__(
        self, plant: Params = REAL, twin: Twin | None = None, *,
        masks: NDArray[np.bool_] | None = None, common_noise: bool = False,
        values: Mapping[str, Any] | None = None, noise: NoiseTable | None = None,
    ) -> None:  # fmt: skip
        self.twin = twin if twin is not None else default_twin()
        self.plant = plant
        self.values = values
        self.masks = self.twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        self.common = bool(common_noise)
        self.table = noise
        self.last: dict[str, NDArray[np.float64]] = {}
        self.n = 0

    def reset(self, n: int, seed: int | None = None) -> None:
        """Pack the chain for ``n`` robots and seed the noise; the elements start their
        state at the first call (power-on)."""
        self._pack(SENSOR_CHAIN, self.plant, self.twin, self.masks, self.values, n, {})
        self.n = n
        self.source: Any = (self.table if self.table is not None
                            else _Generator(seed, 1 if self.common else n))  # fmt: skip
        self.last = {}

    @property
    def columns(self) -> int:
        """Noise columns: 1 (common to the batch) or one per robot."""
        return 1 if (self.table is None and self.common) else self.n

    def compiled_loop(self, actuator: Any, n: int, n_samples: int) -> Any:
        """The engine's hook (:func:`mwip.sim.engine.simulate`): this sensor and ``actuator``
        (a :class:`TwinActuator`) as a compiled loop around a packed law
        (:mod:`mwip.hardware.loop`), or ``None`` where the Python loop stays (a subclass of
        either, another actuator, a chain already past its first sample). Called after the
        first measurement."""
        if type(self) is not TwinSensor or type(actuator) is not TwinActuator:
            return None
        if self.k != 1 or actuator.k != 0 or actuator.n != n:
            return None
        return TwinRun(self, actuator, n, n_samples)

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        from mwip.hardware.loop import sense_batch

        if self.chain.empty:
            self.k += 1
            return Measurement(t=t, y=state.copy())
        n = state.shape[0]
        Z = self.source.draw(self.k, self.k + 1, self.chain.noise)
        LG = np.zeros((n, max(self.chain.log_width, 1)))
        YM = np.empty((n, 8))
        sense_batch(self.k, np.ascontiguousarray(state, dtype=float), self.chain.P, self.X,
                    self.chain.plan, Z, LG, YM)  # fmt: skip
        self.k += 1
        self.last = {k_: v.copy() for k_, v in self.chain.split_logs(LG).items()}
        return Measurement(t=t, y=YM)


class TwinActuator(_Chained):
    """Actuator protocol: the twin's drive chain for a batch (per sample and wheel: the
    optional command disturbances of ``mwip bench``, the firmware's delay and torque-to-duty
    map, the motors and PWM driver, gearbox Coulomb friction and backlash; per robot as its
    element switches say). ``last`` holds the chain's logs of the last call (``drive_duty``,
    ``drive_current``, ``drive_voltage``, ``drive_supply``, ``drive_torque``,
    ``drive_limited``, ``drive_friction``)."""

    def __init__(
        self, plant: Params = REAL, twin: Twin | None = None, *,
        masks: NDArray[np.bool_] | None = None, values: Mapping[str, Any] | None = None,
        command: Mapping[str, Any] | None = None, noise: NoiseTable | None = None,
        mobility: ArrayLike | None = None,
    ) -> None:  # fmt: skip
        self.twin = twin if twin is not None else default_twin()
        self.plant = plant
        self.values = values
        self.masks = self.twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        self.extra: dict[str, Any] = {"command": command}
        self.extra["mobility"] = (relative_mobility(plant) if mobility is None
                                  else np.asarray(mobility, dtype=float))  # fmt: skip
        self.table = noise
        self.n = 0
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Pack the chain for ``n`` robots: currents, the delay line and the backlash at
        rest."""
        self._pack(DRIVE_CHAIN, self.plant, self.twin, self.masks, self.values, n, self.extra)
        self.n = n
        if self.chain.noise and self.table is None:
            raise ValueError("the command noise needs its variates (noise=NoiseTable(...))")
        self.last = {}

    def draw(self, k0: int, k1: int) -> NDArray[np.float64]:
        """The chain's variates of samples ``k0 .. k1 - 1``: (k1 - k0, V, N) or (., 0, 1)."""
        if self.chain.noise == 0:
            return np.zeros((max(k1 - k0, 1), 0, 1))
        assert self.table is not None
        return self.table.draw(k0, k1, self.chain.noise)

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        from mwip.hardware.loop import drive_batch

        u_cmd = np.asarray(u_cmd, dtype=float)
        if self.chain.empty:
            self.k += 1
            self.last = {"drive_limited": np.zeros_like(u_cmd)}
            return u_cmd
        n = u_cmd.shape[0]
        Z = self.draw(self.k, self.k + 1)
        LG = np.zeros((n, max(self.chain.log_width, 1)))
        UA = np.empty((n, 2))
        drive_batch(self.k, np.ascontiguousarray(state, dtype=float),
                    np.ascontiguousarray(u_cmd), self.chain.P, self.X, self.chain.plan, Z, LG,
                    UA)  # fmt: skip
        self.k += 1
        self.last = {k_: v.copy() for k_, v in self.chain.split_logs(LG).items()}
        return UA


class TwinRun:
    """The compiled twin loop of a sensor (after its first sample) and an actuator (before
    its first), prepared by :meth:`TwinSensor.compiled_loop`: called by the engine with the
    packed law, the disturbance by chunks of samples and the run's arrays, it fills them and
    returns the extra logs: ``u_applied``; ``y_meas`` with the sensor's
    ``record_measurement``; the elements' logs with its ``record_logs``."""

    def __init__(self, sensor: TwinSensor, actuator: TwinActuator, n: int,
                 n_samples: int) -> None:  # fmt: skip
        self.sensor, self.actuator, self.n, self.n_samples = sensor, actuator, n, n_samples

    def function(self) -> Any:
        """The compiled loop this run calls: threaded for batches of ``PARALLEL_MIN`` or more."""
        from mwip.hardware import loop
        from mwip.sim.codes import PARALLEL_MIN

        return loop.run_parallel if self.n >= PARALLEL_MIN else loop.run

    def __call__(self, first: NDArray[np.float64], y: NDArray[np.float64], coef: NDArray,
                 tau: Callable[[int, int], NDArray], column: NDArray[np.int64], method: int,
                 dt: float, n_sub: int, Ts: float, rec_idx: NDArray[np.int64], code: int,
                 P: NDArray, X: NDArray, states: NDArray, us: NDArray, log_arr: NDArray,
                 status: NDArray, t_end: NDArray) -> dict[str, NDArray[np.float64]]:  # fmt: skip
        from mwip.hardware import loop

        n, n_samples = self.n, self.n_samples
        sen, act = self.sensor, self.actuator
        sc, dc = sen.chain, act.chain
        cols = max(sen.columns if sc.noise else 1, n if dc.noise else 1)
        width = sc.noise + dc.noise
        per_sample = tau(0, 1).size + width * cols
        chunk = max(16, loop.CHUNK_NUMBERS // max(per_sample, 1))
        measured = sen.record_measurement
        u_app = np.full((n, rec_idx.size, 10 if measured else 2), np.nan)
        keep = sen.record_logs
        ls = sc.log_width
        LG0 = np.zeros((n, ls))
        if ls:  # the first sample's logs, from the engine's first call
            col = 0
            for name_i, w in sc.logs:
                LG0[:, col : col + w] = np.asarray(sen.last[name_i], dtype=float).reshape(n, w)
                col += w
        width_logs = ls + dc.log_width if keep else 0
        elogs = np.full((n, rec_idx.size if keep else 0, width_logs), np.nan)
        M0 = np.ascontiguousarray(first, dtype=float)
        RUN = np.zeros((n, 3), dtype=np.int64)  # next record row, left, disturbance column
        RUN[:, 2] = column
        fn = self.function()
        SX, DX = sen.X, act.X
        for k0 in range(0, n_samples + 1, chunk):
            k1 = min(k0 + chunk, n_samples + 1)
            tk = tau(k0, min(k1, n_samples)) if k0 < n_samples else tau(0, 1)
            Z = np.zeros((k1 - k0, width, cols))
            if sc.noise:  # the sensor's variates of samples max(k0, 1) ..; sample 0's are drawn
                s0 = max(k0, 1)
                if k1 > s0:
                    Z[s0 - k0 :, : sc.noise, :] = sen.source.draw(s0, k1, sc.noise)
            if dc.noise:
                Z[:, sc.noise :, :] = act.draw(k0, k1)
            fn(y, coef, tk, method, dt, n_sub, n_samples, Ts, rec_idx, np.int64(code), P, X,
               M0, Z, sc.P, SX, sc.plan, dc.P, DX, dc.plan, LG0, states, us, log_arr, u_app,
               elogs, status, t_end, np.int64(k0), np.int64(k1), RUN)  # fmt: skip
            if bool(RUN[:, 1].all()):
                break
        out: dict[str, NDArray[np.float64]] = {"u_applied": u_app[:, :, :2].copy()}
        if measured:
            out["y_meas"] = u_app[:, :, 2:].copy()
        if keep:
            out.update({k_: v.copy() for k_, v in sc.split_logs(elogs[:, :, :ls]).items()})
            out.update({k_: v.copy() for k_, v in dc.split_logs(elogs[:, :, ls:]).items()})
        return out


class _Logged:
    """Forwards a controller unchanged (its packed law too, so that it runs in the compiled
    twin loop) and adds the measurement and the twin's logs to its logs in the Python loop."""

    def __init__(self, controller: Controller, sensor: TwinSensor, actuator: TwinActuator,
                 element_logs: bool = True) -> None:  # fmt: skip
        self._c = controller
        self._sensor = sensor
        self._act = actuator
        self._elements = element_logs
        self._meas: NDArray[np.float64] | None = None
        self.Ts = getattr(controller, "Ts", None)
        self.static = False

    def reset(self, meas: Measurement) -> None:
        self._meas = meas.y
        self._c.reset(meas)

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        self._meas = meas.y
        return self._c(t, meas)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        get = getattr(self._c, "log", None)
        out = dict(get()) if get is not None else {}
        if self._meas is not None:
            out["y_meas"] = self._meas
        if self._elements:
            out.update(self._act.last)
            out.update(self._sensor.last)
        return out

    def packed_law(self) -> Any:
        """The controller's own packed law, unless the controller's class overrides what the
        Python loop calls below the class that packs it."""
        from mwip.sim.engine import _overrides_below_packed_law

        get = getattr(self._c, "packed_law", None)
        if get is None or _overrides_below_packed_law(type(self._c)):
            return None
        return get()


def case_plant(
    case: int, base: Params = REAL, twin: Twin | None = None,
    values: Mapping[str, Any] | None = None,
) -> Params:  # fmt: skip
    """The plant of a Chapter 6 case: 1 the robot, 2 and 3 with the payload of ``twin``
    (default: the default twin's, :class:`~mwip.hardware.payload.PayloadSpec`), or with the
    per-row ``payload.height`` / ``payload.radius`` of ``values`` (:meth:`Twin.row_values`;
    the plant then has one row per twin)."""
    if case not in CASES:
        raise ValueError(f"'case' must be one of {sorted(CASES)}, got {case!r}")
    if case == 1:
        return base
    pay = twin.payload if twin is not None else PayloadSpec()
    height: Any = pay.height
    radius: Any = pay.radius
    if values is not None:
        height = values.get("payload.height", height)
        radius = values.get("payload.radius", radius)
    return base.with_payload(pay.mass, height, pan_radius=radius)


def stick_for(
    plant: Params, speed: float = -7.0, start: float = 6.0, height: float = 0.01
) -> StickObstacle:
    """The Case 3 stick of ``height`` for ``plant`` (its total mass and wheel radius)."""
    mass = float(np.mean(plant.mb + 2.0 * plant.mw))
    return StickObstacle(height=height, start=start, speed=speed, mass=mass,
                         r=float(np.mean(plant.r)))  # fmt: skip


def run_on_twin(
    controller: Controller,
    case: int = 1,
    *,
    twin: Twin | None = None,
    plant: Params | None = None,
    q0: ArrayLike = (0.0, np.pi / 18, 0.0),
    qdot0: ArrayLike = (0.0, 0.0, 0.0),
    duration: float = 10.0,
    record_every: int = 2,
    seed: int = 0,
    disturbance: Disturbance | None = None,
    stick_speed: float = -7.0,
    stick_start: float = 6.0,
    stick_height: float | None = None,
    rows: Iterable[Iterable[str]] | None = None,
    common_noise: bool | None = None,
    progress: Callable[[int], None] | None = None,
    values: Mapping[str, ArrayLike] | None = None,
    base: Params | None = None,
    drive_logs: bool = True,
) -> SimResult:
    """Run ``controller`` (any mwip controller, unchanged) on the twin for a Chapter 6 case.

    Records every ``record_every`` samples (2 x 5 ms = the book's 10 ms records for (6.3)).
    ``plant`` overrides the case's plant (before the twin adds its drive train,
    :meth:`Twin.plant`), which is otherwise ``base`` (default: Table 6.1's robot) with the
    twin's payload for cases 2 and 3 (:func:`case_plant`); case 3 adds the stick (height
    ``stick_height`` if given, else the twin's ``stick.height``; timed for ``stick_speed``) to
    ``disturbance``. ``rows``: a batch of twins with these element sets (one controller
    instance drives them all, so it must be batch-capable). ``values``: a batch of N twins
    that differ in their unknowns (``{dotted name: (N,) array}``, :mod:`mwip.hardware.prior`),
    row ``i`` being ``twin.with_values({k: values[k][i]})``; with ``rows`` too, ``rows`` must
    have N entries (row ``i`` both). ``common_noise`` (default: true with ``rows`` or
    ``values``) gives every row the IMU noise of a single run with the same seed, scaled by
    its own sigmas, so row ``i`` equals that single run. The logs carry the
    measurement (``y_meas``), the drive's ``duty``, ``current``, ``voltage``, ``supply``,
    ``torque`` (whole motor torque), ``limited``, ``friction`` and the IMU's raw tilt and gyro
    beside the controller's own logs and the applied torque ``u_applied`` (the held part: a
    voltage drive's back-EMF torque is in the plant's ``Db``). ``progress(k)`` is called as
    samples complete (as :func:`mwip.sim.engine.simulate`). ``drive_logs=False`` keeps of the
    twin's logs only ``y_meas`` and ``u_applied`` (less memory for large batches). A
    controller with a packed law runs in the compiled twin loop (:mod:`mwip.hardware.loop`),
    any other in the engine's Python loop on the same compiled elements.
    """
    tw = twin if twin is not None else default_twin()
    rows = None if rows is None else [list(r) for r in rows]
    vals: dict[str, Any] | None = None
    n_batch = None if rows is None else len(rows)
    if values is not None:
        vals, n_vals = tw.row_values(values)
        if n_batch is not None and n_batch != n_vals:
            raise ValueError(f"rows has {n_batch} entries, values {n_vals} rows: give equal")
        n_batch = n_vals
        pay = sorted(k for k in values if k.startswith("payload."))
        if pay and plant is not None:
            raise ValueError(
                f"values[{pay[0]!r}] sets the case plant's payload: pass base= (the robot "
                f"before the case), not plant="
            )
        if "stick.height" in values and stick_height is not None:
            raise ValueError("values['stick.height'] and stick_height both given: give one")
    if plant is not None:
        cp = plant
    else:
        cp = case_plant(case, REAL if base is None else base, tw, vals)
    dist = disturbance
    if case == 3:
        heights: Any = tw.stick.height if stick_height is None else stick_height
        if vals is not None and stick_height is None:
            heights = vals["stick.height"]
        if np.ndim(heights) == 0 and cp.batch_shape == ():
            stick: Disturbance = stick_for(cp, stick_speed, stick_start, float(heights))
        else:
            stick = _sticks(cp, stick_speed, stick_start, heights, n_batch)
        dist = stick if dist is None else Sum((dist, stick))
    p = tw.plant(cp, rows, vals)
    if n_batch is not None and p.batch_shape == ():  # nothing per row: broadcast to the batch
        p = _batched(p, n_batch)
    batch = rows is not None or values is not None
    common = batch if common_noise is None else common_noise
    sensor = tw.sensor(p, rows, common_noise=common, values=vals)
    actuator = tw.actuator(p, rows, vals)
    sensor.record_measurement = True
    sensor.record_logs = drive_logs
    return simulate(
        _Logged(controller, sensor, actuator, drive_logs), p, q0=q0, qdot0=qdot0,
        duration=duration,
        Ts=tw.Ts, dt=tw.dt, disturbance=dist, sensor=sensor, actuator=actuator,
        record_every=record_every, seed=seed, progress=progress,
    )  # fmt: skip


def _sticks(plant: Params, speed: float, start: float, heights: Any, n: int | None) -> StickRows:
    """One stick per row (per-row heights, or a batched plant): :func:`stick_for`'s numbers
    for each row."""
    shape = np.broadcast_shapes(plant.batch_shape, np.shape(heights))
    k = shape[0] if shape else (n or 1)
    mass = np.broadcast_to(np.asarray(plant.mb + 2.0 * plant.mw, dtype=float), (k,))
    r = np.broadcast_to(np.asarray(plant.r, dtype=float), (k,))
    h = np.broadcast_to(np.asarray(heights, dtype=float), (k,))
    return StickRows(
        [
            StickObstacle(
                height=float(h[i]), start=start, speed=speed, mass=float(mass[i]), r=float(r[i])
            )
            for i in range(k)
        ]
    )


def _batched(p: Params, n: int) -> Params:
    """``p`` as a batch of ``n`` identical robots (``Db`` carries the batch shape)."""
    from dataclasses import replace

    db: Any = np.broadcast_to(np.asarray(p.Db, dtype=float), (n,)).copy()
    return replace(p, Db=db)
