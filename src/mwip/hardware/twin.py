"""The digital twin of the Chapter 6 robot: plant + sensors + actuators + a 5 ms controller.

:class:`TwinSensor` (the sensor protocol of :mod:`mwip.sim.sensors`) turns the true state into
what the LM3S2965 board computes: pitch and pitch rate from the IMU fused by a complementary or
Kalman filter (:mod:`mwip.hardware.imu`), wheel angle, yaw and their rates from the motor
encoders by differences (:mod:`mwip.hardware.encoder`), position by odometry.
:class:`DriveActuator` (:mod:`mwip.hardware.motor`) turns torque commands into PWM duty,
motor currents and wheel torques with the supply and current limits. :func:`run_on_twin` runs
any mwip controller on it unchanged, for the book's uncertainty cases (:data:`CASES`):

- case 1: the real robot (Table 6.1);
- case 2: with the 0.5 kg pan on 0.1 m rods (:meth:`mwip.params.Params.with_payload`);
- case 3: case 2 crossing a stick at about 6 s (:class:`mwip.hardware.obstacle.StickObstacle`).

The accelerometer needs the body's acceleration: the sensor takes the mean acceleration over
the last sample from the true velocities, ``(q'_k - q'_{k-1}) / Ts`` (what the IMU's
anti-alias/digital low-pass filter at about the sample rate delivers), instead of the
instantaneous acceleration (which after each torque step contains the plant's ~3000 rad/s
damping transients, far above any IMU bandwidth).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Controller, Measurement
from mwip.hardware.encoder import EncoderSpec, count, counts_to_angle
from mwip.hardware.imu import FusionSpec, Imu, ImuNoise, TiltFilter, tilt_arctan
from mwip.hardware.motor import RE25, DriveActuator, DriveSpec, MotorData
from mwip.hardware.obstacle import StickObstacle
from mwip.params import REAL, Params
from mwip.sim.disturbance import Disturbance, Sum
from mwip.sim.engine import simulate
from mwip.sim.result import SimResult

__all__ = ["Twin", "TwinSensor", "DriveActuator", "case_plant", "run_on_twin", "CASES"]

CASES = {1: "real robot (Table 6.1)", 2: "with payload (0.5 kg on 0.1 m rods)",
         3: "with payload, crossing a stick at ~6 s"}  # fmt: skip


@dataclass(frozen=True)
class Twin:
    """Configuration of the twin. ``ideal_sensors`` / ``ideal_actuator`` bypass the hardware
    models (the twin then reproduces the plain simulation exactly)."""

    imu: ImuNoise = field(default_factory=ImuNoise)
    fusion: FusionSpec = field(default_factory=FusionSpec)
    encoder: EncoderSpec = field(default_factory=EncoderSpec)
    motor: MotorData = RE25
    drive: DriveSpec = field(default_factory=DriveSpec)
    Ts: float = 0.005
    dt: float = 0.0005
    ideal_sensors: bool = False
    ideal_actuator: bool = False

    def __post_init__(self) -> None:
        if abs(self.encoder.gear_ratio - self.drive.gear_ratio) > 1e-12:
            raise ValueError(
                f"'encoder.gear_ratio' ({self.encoder.gear_ratio:g}) must equal "
                f"'drive.gear_ratio' ({self.drive.gear_ratio:g}): one gearbox"
            )
        if not (np.isfinite(self.Ts) and 0 < self.Ts <= 1.0):
            raise ValueError(f"'Ts' must be finite and in (0, 1], got {self.Ts!r}")
        if not (np.isfinite(self.dt) and 0 < self.dt <= self.Ts):
            raise ValueError(f"'dt' must be finite and in (0, Ts], got {self.dt!r}")

    @classmethod
    def ideal(cls, **kw: Any) -> Twin:
        """Ideal sensors and actuator: a plumbing check against :func:`mwip.sim.simulate`."""
        return cls(ideal_sensors=True, ideal_actuator=True, **kw)

    def sensor(self, plant: Params) -> TwinSensor:
        """A fresh sensor for ``plant`` (it needs the plant's wheel geometry)."""
        return TwinSensor(plant, self)

    def actuator(self, plant: Params) -> DriveActuator:
        """A fresh drive for ``plant``."""
        return DriveActuator(self.motor, self.drive, plant_b_over_r=float(plant.b / plant.r),
                             Ts=self.Ts, ideal=self.ideal_actuator)  # fmt: skip


class TwinSensor:
    """Sensor protocol: IMU fusion for ``theta, theta'``, encoders for ``psi, alpha`` and
    rates, odometry for ``x, y``. ``last`` holds the raw readings of the last call."""

    def __init__(self, plant: Params = REAL, twin: Twin | None = None) -> None:
        self.twin = twin if twin is not None else Twin()
        self.r = float(plant.r)
        self.b_over_r = float(plant.b / plant.r)
        self.imu = Imu(self.twin.imu)
        self.filter = TiltFilter(self.twin.fusion)
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

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        if self.twin.ideal_sensors:
            return Measurement(t=t, y=state.copy())
        Ts = self.twin.Ts
        n = state.shape[0]
        first = self._prev is None
        if first:
            acc = np.zeros((n, 3))
        else:
            acc = (state[:, 3:6] - self._prev[:, 3:6]) / Ts  # type: ignore[index]
        ax, ay, omega = self.imu.read(state[:, 1], state[:, 4], acc[:, 1], self.r * acc[:, 0],
                                      0.0 if first else Ts)  # fmt: skip
        th_acc = tilt_arctan(ax, ay)  # (2.39)
        if first:
            self.filter.reset(th_acc)
            th_hat, thd_hat = th_acc.copy(), omega.copy()
            self._theta0 = th_hat.copy()
            self._c0 = count(self._relative(state), self.twin.encoder)
            self._rel_prev = np.zeros((n, 2))
            self._origin = state[:, [0, 2, 6, 7]].copy()
            self._pos = state[:, 6:8].copy()
        else:
            th_hat, thd_hat = self.filter.update(omega, th_acc, Ts)
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
        self.last = {"theta_acc": th_acc, "gyro": omega, "gyro_bias": self.imu.bias.copy()}
        return Measurement(t=t, y=y)


class _Logged:
    """Forwards a controller unchanged and adds the twin's readings to its logs."""

    def __init__(self, controller: Controller, sensor: TwinSensor, actuator: DriveActuator) -> None:
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


def stick_for(plant: Params, speed: float = -7.0, start: float = 6.0) -> StickObstacle:
    """The Case 3 stick for ``plant`` (its total mass and wheel radius)."""
    mass = float(plant.mb + 2.0 * plant.mw)
    return StickObstacle(start=start, speed=speed, mass=mass, r=float(plant.r))


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
) -> SimResult:
    """Run ``controller`` (any mwip controller, unchanged) on the twin for a Chapter 6 case.

    Records every ``record_every`` samples (2 x 5 ms = the book's 10 ms records for (6.3)).
    ``plant`` overrides the case's plant; case 3 adds the stick (timed for ``stick_speed``)
    to ``disturbance``. The logs carry the measurement (``y_meas``), the drive's ``duty``,
    ``current``, ``voltage``, ``limited`` and the IMU's raw tilt and gyro beside the
    controller's own logs and the applied torque ``u_applied``.
    """
    tw = twin if twin is not None else Twin()
    p = plant if plant is not None else case_plant(case)
    dist = disturbance
    if case == 3:
        stick = stick_for(p, stick_speed, stick_start)
        dist = stick if dist is None else Sum((dist, stick))
    sensor = tw.sensor(p)
    actuator = tw.actuator(p)
    return simulate(
        _Logged(controller, sensor, actuator), p, q0=q0, qdot0=qdot0, duration=duration,
        Ts=tw.Ts, dt=tw.dt, disturbance=dist, sensor=sensor, actuator=actuator,
        record_every=record_every, seed=seed,
    )  # fmt: skip
