"""The digital twin of the Chapter 6 robot: plant + drive train + sensors + a 5 ms controller.

:class:`Twin` is the configuration (data: :mod:`mwip.hardware.twin_config` reads and writes it
as ``[twin]`` TOML tables, ``mwip twin show``); every physical effect is an *element*
(:mod:`mwip.hardware.elements`) that can be switched off, and ``Twin.ideal()`` switches all
off (the plain simulation, bit for bit). The pieces:

- the plant (:meth:`Twin.plant`): the case's parameters plus the rotor inertia reflected
  through the gearbox and, for a voltage drive, the back-EMF damping on ``Db``
  (:mod:`mwip.hardware.drivetrain`);
- :class:`TwinSensor` (sensor protocol, :mod:`mwip.sim.sensors`): what the LM3S2965 board
  computes: pitch and pitch rate from the IMU fused by a complementary or Kalman filter
  (:mod:`mwip.hardware.imu`), wheel angle, yaw and their rates from the motor encoders by
  differences (:mod:`mwip.hardware.encoder`), position by odometry;
- :class:`TwinActuator` (actuator protocol): the computation delay, the RE25 motors and PWM
  driver (:class:`mwip.hardware.motor.DriveActuator`), gearbox friction and backlash.

:func:`run_on_twin` runs any mwip controller on it unchanged, for the book's uncertainty
cases (:data:`CASES`):

- case 1: the real robot (Table 6.1);
- case 2: with the 0.5 kg pan on 0.1 m rods (:meth:`mwip.params.Params.with_payload`);
- case 3: case 2 crossing a stick at about 6 s (:class:`mwip.hardware.obstacle.StickObstacle`).

With ``rows`` it runs one controller on a batch of twins that differ only in their elements
(the ablation of :mod:`mwip.hardware.ablation`); with ``common_noise`` (the default there)
every row sees the IMU noise of a single run with the same seed.

The accelerometer needs the body's acceleration: the sensor takes the mean acceleration over
the last sample from the true velocities, ``(q'_k - q'_{k-1}) / Ts`` (what the IMU's
anti-alias/digital low-pass filter at about the sample rate delivers), instead of the
instantaneous acceleration.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Controller, Measurement
from mwip.hardware.drivetrain import (
    Backlash,
    GearboxSpec,
    coulomb_torque,
    derive_plant,
    relative_mobility,
)
from mwip.hardware.elements import (
    DRIVE_ELEMENTS,
    ELEMENTS,
    PLANT_ELEMENTS,
    SENSOR_ELEMENTS,
    check_elements,
    element_mask,
)
from mwip.hardware.encoder import EncoderSpec, count, counts_to_angle
from mwip.hardware.imu import FusionSpec, Imu, ImuNoise, TiltFilter, tilt_arctan
from mwip.hardware.motor import RE25, DriveActuator, DriveSpec, MotorData
from mwip.hardware.obstacle import StickObstacle
from mwip.params import REAL, Params
from mwip.sim.disturbance import Disturbance, Sum
from mwip.sim.engine import simulate
from mwip.sim.result import SimResult

__all__ = [
    "Twin", "TwinSensor", "TwinActuator", "DriveActuator", "case_plant", "run_on_twin",
    "CASES", "stick_for",
]  # fmt: skip

CASES = {1: "real robot (Table 6.1)", 2: "with payload (0.5 kg on 0.1 m rods)",
         3: "with payload, crossing a stick at ~6 s"}  # fmt: skip

_IDX = {e: i for i, e in enumerate(ELEMENTS)}


@dataclass(frozen=True)
class Twin:
    """Configuration of the twin (defaults and their sources: docs/twin_model.md).

    ``elements`` are the physical effects switched on (:data:`mwip.hardware.elements.ELEMENTS`,
    all by default); ``ideal_sensors`` / ``ideal_actuator`` switch off all sensor / all
    drive-train elements (the twin then reproduces the plain simulation exactly).
    ``delay`` is the computation and actuation delay as a fraction of ``Ts`` in [0, 1]
    (assumed 0.2: 1 ms of a 5 ms loop on the 50 MHz Cortex-M3 without FPU).
    """

    imu: ImuNoise = field(default_factory=ImuNoise)
    fusion: FusionSpec = field(default_factory=FusionSpec)
    encoder: EncoderSpec = field(default_factory=EncoderSpec)
    motor: MotorData = RE25
    drive: DriveSpec = field(default_factory=DriveSpec)
    Ts: float = 0.005
    dt: float = 0.0005
    ideal_sensors: bool = False
    ideal_actuator: bool = False
    gearbox: GearboxSpec = field(default_factory=GearboxSpec)
    delay: float = 0.2
    elements: frozenset[str] = frozenset(ELEMENTS)

    def __post_init__(self) -> None:
        object.__setattr__(self, "elements", check_elements(self.elements))
        if abs(self.encoder.gear_ratio - self.drive.gear_ratio) > 1e-12:
            raise ValueError(
                f"'encoder.gear_ratio' ({self.encoder.gear_ratio:g}) must equal "
                f"'drive.gear_ratio' ({self.drive.gear_ratio:g}): one gearbox"
            )
        if not (np.isfinite(self.Ts) and 0 < self.Ts <= 1.0):
            raise ValueError(f"'Ts' must be finite and in (0, 1], got {self.Ts!r}")
        if not (np.isfinite(self.dt) and 0 < self.dt <= self.Ts):
            raise ValueError(f"'dt' must be finite and in (0, Ts], got {self.dt!r}")
        if not (np.isfinite(self.delay) and 0.0 <= self.delay <= 1.0):
            raise ValueError(f"'delay' must be finite and in [0, 1] (of Ts), got {self.delay!r}")

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

    def plant(self, base: Params, rows: Iterable[Iterable[str]] | None = None) -> Params:
        """The plant the twin integrates for the case plant ``base``: the reflected rotor
        inertia (``inertia``), the back-EMF damping of a voltage drive (``motor``) and the
        gearbox's viscous friction (``friction``) on ``Db`` (:mod:`mwip.hardware.drivetrain`).
        One row per entry of ``rows`` (a batch), else ``base``'s own shape."""
        m = self.masks(rows)
        col = (lambda e: m[:, _IDX[e]]) if rows is not None else (lambda e: m[0, _IDX[e]])
        emf = self.drive.emf_damping(self.motor) if self.drive.mode == "voltage" else 0.0
        extra = col("motor") * emf + col("friction") * self.gearbox.viscous
        return derive_plant(base, inertia=col("inertia"), extra_db=extra,
                            gear_ratio=self.drive.gear_ratio,
                            rotor_inertia=self.motor.rotor_inertia)  # fmt: skip

    def sensor(
        self, plant: Params, rows: Iterable[Iterable[str]] | None = None, *,
        common_noise: bool = False,
    ) -> TwinSensor:  # fmt: skip
        """A fresh sensor for ``plant`` (it needs the plant's wheel geometry)."""
        return TwinSensor(plant, self, masks=self.masks(rows), common_noise=common_noise)

    def actuator(self, plant: Params, rows: Iterable[Iterable[str]] | None = None) -> TwinActuator:
        """A fresh drive for ``plant``."""
        return TwinActuator(self, plant_b_over_r=float(np.mean(plant.b / plant.r)),
                            masks=self.masks(rows), mobility=relative_mobility(plant))  # fmt: skip


def _col(masks: NDArray[np.bool_], name: str) -> NDArray[np.bool_]:
    return masks[:, _IDX[name]]


class TwinActuator:
    """Actuator protocol: delay, motor + driver, gearbox friction and backlash, per row.

    Per sample ``k`` and wheel, with the commanded ``u_k``:

    1. ``delay`` (fraction ``d`` of ``Ts``): the board writes the new duty ``d Ts`` after the
       sample instant, so the torque command held over the sample is
       ``d u_{k-1} + (1 - d) u_k`` (exact for ``d = 0`` and ``d = 1``, a one-sample shift;
       for a fraction the sample's mean);
    2. ``motor`` (:class:`~mwip.hardware.motor.DriveActuator`, with ``pwm`` and ``sag``): the
       torque the motor delivers (the back-EMF term of a voltage drive is in the plant's
       ``Db``); without it the command is applied as a torque;
    3. ``friction``: Coulomb friction held over the sample
       (:func:`~mwip.hardware.drivetrain.coulomb_torque`);
    4. ``backlash`` (:class:`~mwip.hardware.drivetrain.Backlash`).

    ``last`` holds the drive's logs (``duty``, ``current``, ``voltage``, ``supply``,
    ``torque``, ``limited``) and ``friction``.
    """

    def __init__(
        self,
        twin: Twin,
        *,
        plant_b_over_r: float,
        masks: NDArray[np.bool_] | None = None,
        mobility: ArrayLike = 1.0 / 2e-3,
    ) -> None:
        self.twin = twin
        self.mobility = np.asarray(mobility, dtype=float)
        self.masks = twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        m = self.masks
        self.b_over_r = float(plant_b_over_r)
        self.drive = DriveActuator(
            twin.motor, twin.drive, plant_b_over_r=self.b_over_r, Ts=twin.Ts,
            pwm=_col(m, "pwm"), sag=_col(m, "sag"), emf_in_plant=True,
        )  # fmt: skip
        n2j = twin.drive.gear_ratio**2 * twin.motor.rotor_inertia
        self.backlash = Backlash(_col(m, "backlash") * twin.gearbox.backlash, n2j, twin.Ts)
        idx = [_IDX[e] for e in sorted(DRIVE_ELEMENTS)]
        self.any = bool(np.any(m[:, idx]))
        self.u_prev = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Currents, the delay line and the backlash to rest."""
        self.drive.reset(n, seed)
        self.backlash.reset(n)
        self.u_prev = np.zeros((n, 2))
        self.last = {}

    def _rows(self, name: str, n: int) -> NDArray[np.bool_]:
        return np.broadcast_to(_col(self.masks, name), (n,))[:, None]

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        u_cmd = np.asarray(u_cmd, dtype=float)
        if not self.any:
            self.last = {"limited": np.zeros_like(u_cmd)}
            return u_cmd
        n = u_cmd.shape[0]
        if self.u_prev.shape != u_cmd.shape:
            self.reset(n)
        d = self.twin.delay * self._rows("delay", n)
        u = d * self.u_prev + (1.0 - d) * u_cmd
        self.u_prev = u_cmd.copy()
        motor = self._rows("motor", n)
        if motor.any():
            u = np.where(motor, self.drive(t, u, state), u)
            last = dict(self.drive.last)
        else:
            last = {"limited": np.zeros_like(u)}
        fric = np.zeros_like(u)
        if self._rows("friction", n).any():
            w = self.drive.motor_speed(state) / self.twin.drive.gear_ratio
            fc = self.twin.gearbox.coulomb * self._rows("friction", n)
            mob = np.broadcast_to(self.mobility, (n,))[:, None]
            fric = coulomb_torque(w, u, fc, mob, self.twin.Ts)
            u = u + fric
        if self._rows("backlash", n).any():
            u = self.backlash(u)
        last["friction"] = fric
        self.last = last
        return u


class TwinSensor:
    """Sensor protocol: IMU fusion for ``theta, theta'``, encoders for ``psi, alpha`` and
    rates, odometry for ``x, y``, per row as the elements say (``encoder``, ``fusion``,
    ``accel_motion``, ``imu_noise``, ``imu_bias``); a row without ``encoder`` gets the true
    ``psi, alpha``, rates and position, one without ``fusion`` the true ``theta, theta'``.
    ``last`` holds the raw readings of the last call."""

    def __init__(
        self, plant: Params = REAL, twin: Twin | None = None, *,
        masks: NDArray[np.bool_] | None = None, common_noise: bool = False,
    ) -> None:  # fmt: skip
        self.twin = twin if twin is not None else Twin()
        self.masks = self.twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        self.r = float(np.mean(plant.r))
        self.b_over_r = float(np.mean(plant.b / plant.r))
        self.imu = Imu(self.twin.imu, common=common_noise)
        self.filter = TiltFilter(self.twin.fusion)
        idx = [_IDX[e] for e in sorted(SENSOR_ELEMENTS)]
        self.any = bool(self.masks[:, idx].any())
        self._prev: NDArray[np.float64] | None = None
        self._theta0 = np.zeros(0)
        self._c0 = np.zeros((0, 2), dtype=np.int64)
        self._rel_prev = np.zeros((0, 2))
        self._origin = np.zeros((0, 4))
        self._pos = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Seed the noise; filters and counters start at the first call."""
        self.imu.reset(n, seed)
        self._prev = None
        self.last = {}

    def _relative(self, state: NDArray[np.float64]) -> NDArray[np.float64]:
        psi, th, al = state[:, 0], state[:, 1], state[:, 2]
        return np.column_stack([psi + self.b_over_r * al - th, psi - self.b_over_r * al - th])

    def _on(self, name: str, n: int) -> NDArray[np.bool_]:
        return np.broadcast_to(_col(self.masks, name), (n,))

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        if not self.any:
            return Measurement(t=t, y=state.copy())
        Ts = self.twin.Ts
        n = state.shape[0]
        first = self._prev is None
        if first:
            acc = np.zeros((n, 3))
        else:
            acc = (state[:, 3:6] - self._prev[:, 3:6]) / Ts  # type: ignore[index]
        ax, ay, omega = self.imu.read(
            state[:, 1], state[:, 4], acc[:, 1], self.r * acc[:, 0], 0.0 if first else Ts,
            noise=self._on("imu_noise", n), bias=self._on("imu_bias", n),
            motion=self._on("accel_motion", n),
        )  # fmt: skip
        th_acc = tilt_arctan(ax, ay)  # (2.39)
        fusion = self._on("fusion", n)
        if first:
            self.filter.reset(th_acc)
            th_hat, thd_hat = th_acc.copy(), omega.copy()
        else:
            th_hat, thd_hat = self.filter.update(omega, th_acc, Ts)
        th_hat = np.where(fusion, th_hat, state[:, 1])
        thd_hat = np.where(fusion, thd_hat, state[:, 4])
        if first:
            self._theta0 = th_hat.copy()
            self._c0 = count(self._relative(state), self.twin.encoder)
            self._rel_prev = np.zeros((n, 2))
            self._origin = state[:, [0, 2, 6, 7]].copy()
            self._pos = state[:, 6:8].copy()
        rel = counts_to_angle(count(self._relative(state), self.twin.encoder) - self._c0,
                              self.twin.encoder)  # fmt: skip
        rel_rate = (rel - self._rel_prev) / Ts if not first else np.zeros((n, 2))
        self._rel_prev = rel
        psi = self._origin[:, 0] + rel.mean(axis=1) + th_hat - self._theta0
        alpha = self._origin[:, 1] + (rel[:, 0] - rel[:, 1]) / (2.0 * self.b_over_r)
        psi_dot = rel_rate.mean(axis=1) + thd_hat
        alpha_dot = (rel_rate[:, 0] - rel_rate[:, 1]) / (2.0 * self.b_over_r)
        if not first:
            v = self.r * psi_dot
            self._pos = self._pos + Ts * np.column_stack([v * np.cos(alpha), v * np.sin(alpha)])
        self._prev = state.copy()
        y = np.column_stack([psi, th_hat, alpha, psi_dot, thd_hat, alpha_dot, self._pos])
        enc = self._on("encoder", n)[:, None]
        y[:, [0, 2, 3, 5, 6, 7]] = np.where(enc, y[:, [0, 2, 3, 5, 6, 7]],
                                            state[:, [0, 2, 3, 5, 6, 7]])  # fmt: skip
        y[:, 1] = th_hat
        y[:, 4] = thd_hat
        self.last = {"theta_acc": th_acc, "gyro": omega, "gyro_bias": self.imu.bias.copy()}
        return Measurement(t=t, y=y)


class _Logged:
    """Forwards a controller unchanged and adds the twin's readings to its logs."""

    def __init__(self, controller: Controller, sensor: TwinSensor, actuator: TwinActuator) -> None:
        self._c = controller
        self._sensor = sensor
        self._act = actuator
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
        for k, v in self._act.last.items():
            out[f"drive_{k}"] = v
        for k, v in self._sensor.last.items():
            out[f"imu_{k}"] = v
        return out


def case_plant(case: int, base: Params = REAL) -> Params:
    """The plant of a Chapter 6 case: 1 the robot, 2 and 3 with the payload."""
    if case not in CASES:
        raise ValueError(f"'case' must be one of {sorted(CASES)}, got {case!r}")
    return base if case == 1 else base.with_payload()


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
    stick_height: float = 0.01,
    rows: Iterable[Iterable[str]] | None = None,
    common_noise: bool | None = None,
    progress: Callable[[int], None] | None = None,
) -> SimResult:
    """Run ``controller`` (any mwip controller, unchanged) on the twin for a Chapter 6 case.

    Records every ``record_every`` samples (2 x 5 ms = the book's 10 ms records for (6.3)).
    ``plant`` overrides the case's plant (before the twin adds its drive train,
    :meth:`Twin.plant`); case 3 adds the stick (``stick_height``, timed for ``stick_speed``) to
    ``disturbance``. ``rows``: a batch of twins with these element sets (one controller
    instance drives them all, so it must be batch-capable); ``common_noise`` (default: true
    with ``rows``) gives every row the IMU noise of a single run. The logs carry the
    measurement (``y_meas``), the drive's ``duty``, ``current``, ``voltage``, ``supply``,
    ``torque`` (whole motor torque), ``limited``, ``friction`` and the IMU's raw tilt and gyro
    beside the controller's own logs and the applied torque ``u_applied`` (the held part: a
    voltage drive's back-EMF torque is in the plant's ``Db``). ``progress(k)`` is called as
    samples complete (as :func:`mwip.sim.engine.simulate`).
    """
    tw = twin if twin is not None else Twin()
    base = plant if plant is not None else case_plant(case)
    rows = None if rows is None else [list(r) for r in rows]
    dist = disturbance
    if case == 3:
        stick = stick_for(base, stick_speed, stick_start, stick_height)
        dist = stick if dist is None else Sum((dist, stick))
    p = tw.plant(base, rows)
    if rows is not None and p is base:  # nothing derived: broadcast to the batch
        p = _batched(base, len(rows))
    common = rows is not None if common_noise is None else common_noise
    sensor = tw.sensor(p, rows, common_noise=common)
    actuator = tw.actuator(p, rows)
    return simulate(
        _Logged(controller, sensor, actuator), p, q0=q0, qdot0=qdot0, duration=duration,
        Ts=tw.Ts, dt=tw.dt, disturbance=dist, sensor=sensor, actuator=actuator,
        record_every=record_every, seed=seed, progress=progress,
    )  # fmt: skip


def _batched(p: Params, n: int) -> Params:
    """``p`` as a batch of ``n`` identical robots (``Db`` carries the batch shape)."""
    from dataclasses import replace

    db: Any = np.broadcast_to(np.asarray(p.Db, dtype=float), (n,)).copy()
    return replace(p, Db=db)
