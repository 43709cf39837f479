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
(the ablation of :mod:`mwip.hardware.ablation`); with ``values`` on a batch of twins that
differ in their unknown values (:mod:`mwip.hardware.prior`: row ``i`` is
``twin.with_values({k: values[k][i]})``, every element taking its parameters per row); with
``common_noise`` (the default for both) every row sees the IMU noise of a single run with the
same seed.

The accelerometer needs the body's acceleration: the sensor takes the mean acceleration over
the last sample from the true velocities, ``(q'_k - q'_{k-1}) / Ts`` (what the IMU's
anti-alias/digital low-pass filter at about the sample rate delivers), instead of the
instantaneous acceleration.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

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
from mwip.hardware.identified import default_twin
from mwip.hardware.imu import FusionSpec, Imu, ImuNoise, TiltFilter, tilt_arctan
from mwip.hardware.motor import RE25, DriveActuator, DriveSpec, MotorData
from mwip.hardware.obstacle import StickObstacle, StickRows, StickSpec
from mwip.hardware.payload import PayloadSpec
from mwip.hardware.unknown import Unknown
from mwip.params import REAL, Params
from mwip.sim.disturbance import Disturbance, Sum
from mwip.sim.engine import simulate
from mwip.sim.result import SimResult

if TYPE_CHECKING:
    from mwip.hardware.prior import Prior

__all__ = [
    "Twin", "TwinSensor", "TwinActuator", "DriveActuator", "case_plant", "run_on_twin",
    "CASES", "stick_for", "UNKNOWNS",
]  # fmt: skip

CASES = {1: "real robot (Table 6.1)", 2: "with payload (0.5 kg on 0.1 m rods)",
         3: "with payload, crossing a stick at ~6 s"}  # fmt: skip

_IDX = {e: i for i, e in enumerate(ELEMENTS)}

#: The twin's own unknown (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("delay", 0.0, 1.0, "Ts", "fraction of Ts: 0-5 ms of computation on the 50 MHz "
            "Cortex-M3", "delay", 0.2),
)  # fmt: skip


def _declared_prior() -> Prior:
    from mwip.hardware.prior import PRIOR

    return PRIOR


@dataclass(frozen=True)
class Twin:
    """Configuration of the twin (defaults and their sources: docs/twin_model.md).

    ``elements`` are the physical effects switched on (:data:`mwip.hardware.elements.ELEMENTS`,
    all by default); ``ideal_sensors`` / ``ideal_actuator`` switch off all sensor / all
    drive-train elements (the twin then reproduces the plain simulation exactly).
    ``delay`` is the computation and actuation delay as a fraction of ``Ts`` in [0, 1]
    (assumed 0.2: 1 ms of a 5 ms loop on the 50 MHz Cortex-M3 without FPU). ``payload`` is
    the Case 2/3 pan, ``stick`` the Case 3 stick; ``prior`` the ranges of the unknown values
    (:mod:`mwip.hardware.prior`; :meth:`values`, :meth:`with_values`).
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
    payload: PayloadSpec = field(default_factory=PayloadSpec)
    stick: StickSpec = field(default_factory=StickSpec)
    prior: Prior = field(default_factory=_declared_prior)

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

    def values(self) -> dict[str, float]:
        """The twin's value of every unknown of :attr:`prior` (dotted names)."""
        return {name: _get(self, name) for name in self.prior.names}

    def with_values(self, mapping: Mapping[str, float]) -> Twin:
        """This twin with the unknowns ``mapping`` (dotted names) replaced; an unknown name or
        a value outside :attr:`prior` is a one-line ``ValueError`` naming it
        (``drive.gear_ratio`` also sets the encoder's)."""
        by_table: dict[str, dict[str, float]] = {}
        top: dict[str, float] = {}
        for name, raw in mapping.items():
            u = self.prior[name] if name in self.prior.names else None
            if u is None:
                raise ValueError(
                    f"with_values: unknown name {name!r}; allowed: {', '.join(self.prior.names)}"
                )
            v = float(raw)
            if not (np.isfinite(v) and u.low <= v <= u.high):
                raise ValueError(
                    f"with_values: {name!r} = {v!r} is outside the prior [{u.low:g}, {u.high:g}]"
                    f" (twin.prior.{name})"
                )
            if "." in name:
                table, key = name.split(".", 1)
                by_table.setdefault(table, {})[key] = v
            else:
                top[name] = v
        kw: dict[str, Any] = dict(top)
        try:
            for table, sub in by_table.items():
                kw[table] = replace(getattr(self, table), **sub)
            if "gear_ratio" in by_table.get("drive", {}):
                kw["encoder"] = replace(self.encoder, gear_ratio=by_table["drive"]["gear_ratio"])
            return replace(self, **kw)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"with_values: {exc}") from None

    def row_values(self, values: Mapping[str, ArrayLike]) -> tuple[dict[str, Any], int]:
        """Validated per-row values of a batch of twins: ``({name: value}, N)`` with every
        unknown of :attr:`prior`: a float (this twin's) or, for those in ``values``, an (N,)
        array (one-line ``ValueError`` naming the key for a wrong shape, a name not in the
        prior or a value outside it)."""
        out: dict[str, Any] = self.values()
        n: int | None = None
        for name, raw in values.items():
            if name not in self.prior.names:
                raise ValueError(
                    f"values: unknown name {name!r}; allowed: {', '.join(self.prior.names)}"
                )
            a = np.asarray(raw, dtype=float)
            if a.ndim != 1 or a.size == 0:
                raise ValueError(f"values[{name!r}] must be a 1-D array, got shape {a.shape}")
            if n is None:
                n = a.size
            elif a.size != n:
                raise ValueError(f"values[{name!r}] has {a.size} rows, the others {n}")
            u = self.prior[name]
            bad = ~(np.isfinite(a) & (a >= u.low) & (a <= u.high))
            if bad.any():
                i = int(np.argmax(bad))
                raise ValueError(
                    f"values[{name!r}][{i}] = {float(a[i])!r} is outside the prior "
                    f"[{u.low:g}, {u.high:g}] (twin.prior.{name})"
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
    ) -> TwinSensor:  # fmt: skip
        """A fresh sensor for ``plant`` (it needs the plant's wheel geometry); ``values``: the
        per-row unknowns of :meth:`row_values`."""
        return TwinSensor(plant, self, masks=self.masks(rows), common_noise=common_noise,
                          values=values)  # fmt: skip

    def actuator(
        self, plant: Params, rows: Iterable[Iterable[str]] | None = None,
        values: Mapping[str, Any] | None = None,
    ) -> TwinActuator:  # fmt: skip
        """A fresh drive for ``plant``; ``values``: the per-row unknowns of
        :meth:`row_values`."""
        return TwinActuator(self, plant_b_over_r=float(np.mean(plant.b / plant.r)),
                            masks=self.masks(rows), mobility=relative_mobility(plant),
                            values=values)  # fmt: skip


def _get(twin: Twin, name: str) -> float:
    obj: Any = twin
    for part in name.split("."):
        obj = getattr(obj, part)
    return float(obj)


def _c(x: Any) -> Any:
    """A per-row value as a column against (N, 2) wheel arrays (a float as it is)."""
    return x if np.ndim(x) == 0 else np.asarray(x, dtype=float)[:, None]


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
        values: Mapping[str, Any] | None = None,
    ) -> None:
        self.twin = twin
        v = twin.values() if values is None else values
        self.values = v
        self.mobility = np.asarray(mobility, dtype=float)
        self.masks = twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        m = self.masks
        self.drive = DriveActuator(
            twin.motor, twin.drive, plant_b_over_r=float(plant_b_over_r), Ts=twin.Ts,
            pwm=_col(m, "pwm"), sag=_col(m, "sag"), emf_in_plant=True,
        )  # fmt: skip
        gr = v["drive.gear_ratio"]
        self.drive.gear_ratio = gr
        self.drive.compensation = (1.0 if twin.drive.mode == "torque"
                                   else v["drive.emf_compensation"])  # fmt: skip
        self.drive.deadband = v["drive.deadband"]
        self.drive.current_limit = v["drive.current_limit"]
        self.gear_ratio = gr
        self.delay = _c(v["delay"])
        self.coulomb = _c(v["gearbox.coulomb"])
        n2j = gr * gr * twin.motor.rotor_inertia
        self.backlash = Backlash(_col(m, "backlash") * v["gearbox.backlash"], n2j, twin.Ts)
        idx = [_IDX[e] for e in sorted(DRIVE_ELEMENTS)]
        self.any = bool(np.any(m[:, idx]))
        self.u_prev = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}


    @property
    def b_over_r(self) -> Any:
        """The plant's ``b / r`` (a number, or one per robot), from which the drive gets each
        wheel's speed: the inner :class:`~mwip.hardware.motor.DriveActuator`'s (one value, so
        setting it here reaches the motor model)."""
        return self.drive.b_over_r

    @b_over_r.setter
    def b_over_r(self, value: Any) -> None:
        self.drive.b_over_r = value

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
        d = self.delay * self._rows("delay", n)
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
            w = self.drive.motor_speed(state) / _c(self.gear_ratio)
            fc = self.coulomb * self._rows("friction", n)
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
    ``last`` holds the raw readings of the last call. ``record_measurement``: the compiled
    twin loop also records the measurement as the log ``y_meas`` (set by :func:`run_on_twin`
    with ``drive_logs=False``)."""

    record_measurement: bool = False

    def __init__(
        self, plant: Params = REAL, twin: Twin | None = None, *,
        masks: NDArray[np.bool_] | None = None, common_noise: bool = False,
        values: Mapping[str, Any] | None = None,
    ) -> None:  # fmt: skip
        self.twin = twin if twin is not None else default_twin()
        v = self.twin.values() if values is None else values
        self.masks = self.twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        self.r = float(np.mean(plant.r))
        self.b_over_r = float(np.mean(plant.b / plant.r))
        self.imu = Imu(self.twin.imu, common=common_noise)
        for key in ("accel_sigma", "accel_bias", "gyro_sigma", "gyro_bias", "height"):
            setattr(self.imu, key, v[f"imu.{key}"])
        self.filter = TiltFilter(self.twin.fusion)
        self.filter.tau = v["fusion.tau"]
        gr = v["drive.gear_ratio"]
        # encoder resolution per row (None: the spec's, the same arithmetic)
        self._res: Any = None
        if np.ndim(gr) != 0:
            self._res = 2.0 * np.pi / (self.twin.encoder.cpr * np.asarray(gr)[:, None])
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

    def compiled_loop(self, actuator: Any, n: int, n_samples: int) -> Any:
        """The engine's hook (:func:`mwip.sim.engine.simulate`): this sensor and ``actuator``
        (a :class:`TwinActuator`) as a compiled loop around a packed law
        (:mod:`mwip.sim.twin_loop`), or ``None`` where the Python loop stays (a subclass
        of either, another actuator, a Kalman filter). Called after the first measurement."""
        if type(self) is not TwinSensor or type(actuator) is not TwinActuator:
            return None
        if self.any and self._prev is None:
            return None
        from mwip.hardware.twin_pack import prepare

        return prepare(self, actuator, n, n_samples)

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
            self._c0 = count(self._relative(state), self.twin.encoder, self._res)
            self._rel_prev = np.zeros((n, 2))
            self._origin = state[:, [0, 2, 6, 7]].copy()
            self._pos = state[:, 6:8].copy()
        enc_spec = self.twin.encoder
        rel = counts_to_angle(count(self._relative(state), enc_spec, self._res) - self._c0,
                              enc_spec, self._res)  # fmt: skip
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


class _Measured(_Logged):
    """:class:`_Logged` that lets a packed controller run in the compiled twin loop
    (:mod:`mwip.sim.twin_loop`, which then records ``y_meas`` itself; the drive and IMU logs
    are the Python loop's only): ``packed_law`` is the controller's own, unless the
    controller's class overrides what the Python loop calls below the class that packs it."""

    def packed_law(self) -> Any:
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
    twin's logs only ``y_meas`` and ``u_applied``, so that a controller with a packed law runs
    in the compiled twin loop (:mod:`mwip.sim.twin_loop`; the same arithmetic, equal to the
    Python loop to round-off, tests/test_twin_loop.py).
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
    if not drive_logs and isinstance(sensor, TwinSensor):
        sensor.record_measurement = True
    wrap = _Logged if drive_logs else _Measured
    return simulate(
        wrap(controller, sensor, actuator), p, q0=q0, qdot0=qdot0, duration=duration,
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
