"""Inertial sensing of the body pitch (Sec. 2.5.1): accelerometer, gyro and their fusion.

Accelerometer (2.37)-(2.39)
    A two-axis accelerometer fixed to the body at ``height`` above the axle measures the
    specific force (acceleration minus gravity) in body axes: ``x`` across the body (forward
    when upright), ``y`` along it (up). Static, ``a_x = g sin(theta)``, ``a_y = g cos(theta)``
    and the tilt follows from (2.37) ``arcsin(a_x / g)`` or (2.39) ``arctan(a_x / a_y)``.
    Moving, the body's own acceleration corrupts both axes (the book's remark after (2.40)):
    :func:`specific_force` includes it exactly for the planar motion (yaw-rate centripetal
    terms neglected).
Gyroscope (2.40)
    ``omega* = theta' + b(t) + n``: white noise ``n`` and a zero drift ``b(t)`` (initial
    offset plus a random walk). Integrating it, ``theta_{k+1} = theta_k + omega* Ts`` (2.40),
    drifts by ``b t``.
Fusion
    A complementary filter (gyro high-passed, accelerometer low-passed, time constant
    ``tau``) and a two-state Kalman filter (angle and gyro bias, gyro as input, accelerometer
    tilt as measurement), both batch-first.

Noise levels (:class:`ImuNoise`) default to a consumer MEMS IMU of the robot's class
(MPU-6050 / ADXL-class data sheets, about 100 Hz bandwidth): see docs/twin.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.hardware.unknown import Unknown

__all__ = [
    "ImuNoise",
    "FusionSpec",
    "specific_force",
    "tilt_arcsin",
    "tilt_arctan",
    "gyro_integrate",
    "complementary_step",
    "kalman_step",
    "Imu",
    "TiltFilter",
    "UNKNOWNS",
]

G = 9.81


def _check(
    name: str, value: float, lo: float, hi: float = np.inf, *, open_lo: bool = False
) -> None:
    ok = np.isfinite(value) and (value > lo if open_lo else value >= lo) and value <= hi
    if not ok:
        left = "(" if open_lo else "["
        raise ValueError(f"{name!r} must be finite and in {left}{lo:g}, {hi:g}], got {value!r}")


@dataclass(frozen=True)
class ImuNoise:
    """Noise, bias and drift of the IMU; all per-sample standard deviations at ``Ts``.

    accel_sigma : white noise on each accelerometer axis (m/s^2); 0.05 ~ 400 ug/sqrt(Hz)
        over a 100 Hz bandwidth.
    accel_bias : constant offset on the x axis (m/s^2); 0.02 ~ 2 mg after calibration.
    gyro_sigma : white noise of the rate (rad/s); 0.002 ~ 0.1 deg/s.
    gyro_bias : zero drift at power-on (rad/s); 0.01 ~ 0.6 deg/s (uncalibrated MEMS).
    gyro_bias_walk : random walk of the zero drift (rad/s/sqrt(s)).
    height : accelerometer height above the axle (m).
    """

    accel_sigma: float = 0.05
    accel_bias: float = 0.02
    gyro_sigma: float = 0.002
    gyro_bias: float = 0.01
    gyro_bias_walk: float = 2e-4
    height: float = 0.1

    def __post_init__(self) -> None:
        _check("accel_sigma", self.accel_sigma, 0.0, 10.0)
        _check("accel_bias", self.accel_bias, -10.0, 10.0)
        _check("gyro_sigma", self.gyro_sigma, 0.0, 10.0)
        _check("gyro_bias", self.gyro_bias, -10.0, 10.0)
        _check("gyro_bias_walk", self.gyro_bias_walk, 0.0, 10.0)
        _check("height", self.height, 0.0, 2.0)

    @classmethod
    def ideal(cls, height: float = 0.1) -> ImuNoise:
        """No noise, bias or drift (the accelerometer still feels the body's acceleration)."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, height)


@dataclass(frozen=True)
class FusionSpec:
    """Which fusion filter and its tuning.

    kind : ``"complementary"`` or ``"kalman"``.
    tau : complementary time constant (s): gyro trusted above ``1/tau``, accelerometer below.
    q_angle : Kalman process noise of the angle (rad^2/s).
    q_bias : Kalman process noise of the gyro bias (rad^2/s^3).
    r_angle : Kalman variance of the accelerometer tilt (rad^2); it covers the sensor noise
        and the motion acceleration (a 0.3 m/s^2 body acceleration is 0.03 rad of tilt error).
    """

    kind: Literal["complementary", "kalman"] = "complementary"
    tau: float = 0.5
    q_angle: float = 1e-4
    q_bias: float = 1e-6
    r_angle: float = 1e-3

    def __post_init__(self) -> None:
        if self.kind not in ("complementary", "kalman"):
            raise ValueError(f"'kind' must be 'complementary' or 'kalman', got {self.kind!r}")
        _check("tau", self.tau, 0.0, 1e3, open_lo=True)
        _check("q_angle", self.q_angle, 0.0, 1.0, open_lo=True)
        _check("q_bias", self.q_bias, 0.0, 1.0)
        _check("r_angle", self.r_angle, 0.0, 1.0, open_lo=True)


def specific_force(
    theta: ArrayLike,
    theta_dot: ArrayLike,
    theta_ddot: ArrayLike,
    x_ddot: ArrayLike,
    height: ArrayLike,
    g: float = G,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body-axis accelerometer readings ``(a_x, a_y)`` at ``height`` above the axle.

    The sensor point is at ``(x_w + h sin theta, h cos theta)``; with the axle's forward
    acceleration ``x'' = r psi''`` its acceleration is
    ``(x'' + h (theta'' cos - theta'^2 sin), -h (theta'' sin + theta'^2 cos))``; the specific
    force ``f = a + (0, g)`` projected on the body axes gives
    ``a_x = (f_z) sin theta - f_x cos theta``, ``a_y = f_z cos theta + f_x sin theta``, so
    that a static body reads ``(g sin theta, g cos theta)`` as assumed by (2.37)-(2.39).
    """
    th = np.asarray(theta, dtype=float)
    td = np.asarray(theta_dot, dtype=float)
    tdd = np.asarray(theta_ddot, dtype=float)
    s, c = np.sin(th), np.cos(th)
    fx = np.asarray(x_ddot, dtype=float) + height * (tdd * c - td**2 * s)
    fz = g - height * (tdd * s + td**2 * c)
    return fz * s - fx * c, fz * c + fx * s


def tilt_arcsin(a_x: ArrayLike, g: float = G) -> NDArray[np.float64]:
    """Single-axis tilt ``arcsin(a_x / g)`` (2.37) (argument clipped to [-1, 1])."""
    return np.arcsin(np.clip(np.asarray(a_x, dtype=float) / g, -1.0, 1.0))


def tilt_arctan(a_x: ArrayLike, a_y: ArrayLike) -> NDArray[np.float64]:
    """Two-axis tilt ``arctan(a_x / a_y)`` (2.39), quadrant-correct (``arctan2``)."""
    return np.arctan2(np.asarray(a_x, dtype=float), np.asarray(a_y, dtype=float))


def gyro_integrate(angle: ArrayLike, omega: ArrayLike, Ts: float) -> NDArray[np.float64]:
    """One step of gyro integration ``alpha_{k+1} = alpha_k + alpha'* Ts`` (2.40)."""
    return np.asarray(angle, dtype=float) + np.asarray(omega, dtype=float) * Ts


def complementary_step(
    angle: ArrayLike, omega: ArrayLike, angle_acc: ArrayLike, Ts: float, tau: ArrayLike
) -> NDArray[np.float64]:
    """Complementary filter: ``a (angle + omega Ts) + (1 - a) angle_acc``, ``a = tau/(tau+Ts)``.

    The gyro path is the integration (2.40); the accelerometer tilt (2.39) corrects its drift
    below ``1 / tau`` rad/s. A constant gyro bias ``b`` leaves a steady error ``b tau``.
    """
    t: Any = tau
    a = t / (t + Ts)
    return a * gyro_integrate(angle, omega, Ts) + (1.0 - a) * np.asarray(angle_acc, dtype=float)


def kalman_step(
    x: NDArray[np.float64],
    P: NDArray[np.float64],
    omega: ArrayLike,
    angle_acc: ArrayLike,
    Ts: float,
    spec: FusionSpec,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One predict/update step of the angle-bias Kalman filter, batch-first.

    State ``x = [angle, bias]`` (N, 2); prediction by the gyro integration (2.40) with the
    bias removed, ``angle += (omega - bias) Ts``; measurement the accelerometer tilt (2.39).
    ``P`` (2, 2) is shared by the batch (its recursion does not depend on the data).
    """
    A = np.array([[1.0, -Ts], [0.0, 1.0]])
    Q = np.diag([spec.q_angle * Ts, spec.q_bias * Ts])
    xp = np.empty_like(x)
    xp[:, 0] = x[:, 0] + (np.asarray(omega, dtype=float) - x[:, 1]) * Ts
    xp[:, 1] = x[:, 1]
    Pp = A @ P @ A.T + Q
    S = Pp[0, 0] + spec.r_angle
    K = Pp[:, 0] / S
    innov = np.asarray(angle_acc, dtype=float) - xp[:, 0]
    xn = xp + innov[:, None] * K[None, :]
    Pn = Pp - np.outer(K, Pp[0, :])
    return xn, 0.5 * (Pn + Pn.T)


class Imu:
    """Stateful IMU of N robots: the gyro's zero drift is a random walk (seeded).

    Every call draws the same normal variates whatever is switched on (bias walk, accel x,
    accel y, gyro: ``n`` each, or one each broadcast to all rows when ``common``), so switching
    an element on or off leaves the others' noise unchanged, and with ``common`` every row of
    a batch sees the noise of a single run with the same seed.
    """

    def __init__(self, noise: ImuNoise = ImuNoise(), *, common: bool = False) -> None:
        self.noise = noise
        self.common = common
        # per-row values (floats, or (N,) arrays set by the twin for a batch of twins)
        self.accel_sigma: Any = noise.accel_sigma
        self.accel_bias: Any = noise.accel_bias
        self.gyro_sigma: Any = noise.gyro_sigma
        self.gyro_bias: Any = noise.gyro_bias
        self.height: Any = noise.height
        self.bias = np.zeros(0)
        self._rng = np.random.default_rng(0)

    def reset(self, n: int, seed: int | None = None) -> None:
        """New noise stream; the zero drift starts at ``gyro_bias``."""
        self._rng = np.random.default_rng(seed)
        if np.ndim(self.gyro_bias) == 0:
            self.bias = np.full(n, self.gyro_bias)
        else:
            self.bias = np.broadcast_to(np.asarray(self.gyro_bias, dtype=float), (n,)).copy()

    def _normal(self, n: int) -> NDArray[np.float64]:
        if self.common:
            return np.broadcast_to(self._rng.standard_normal(1), (n,))
        return self._rng.standard_normal(n)

    def read(
        self,
        theta: NDArray[np.float64],
        theta_dot: NDArray[np.float64],
        theta_ddot: NDArray[np.float64],
        x_ddot: NDArray[np.float64],
        dt: float,
        *,
        noise: ArrayLike = True,
        bias: ArrayLike = True,
        motion: ArrayLike = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(a_x, a_y, omega*)`` for true motion; advances the drift by ``dt`` first.

        ``noise``, ``bias``, ``motion`` (bool, per row) switch the white noise, the offsets
        and drift, and the body-acceleration terms of :func:`specific_force`."""
        nz = self.noise
        n = theta.shape[0]
        on_n = np.broadcast_to(np.asarray(noise, dtype=float), (n,))
        on_b = np.broadcast_to(np.asarray(bias, dtype=float), (n,))
        on_m = np.broadcast_to(np.asarray(motion, dtype=float), (n,))
        walk = self._normal(n)
        if dt > 0:
            self.bias = self.bias + nz.gyro_bias_walk * np.sqrt(dt) * walk
        ax, ay = specific_force(theta, on_m * theta_dot, on_m * theta_ddot, on_m * x_ddot,
                                self.height)  # fmt: skip
        ax = ax + on_n * self.accel_sigma * self._normal(n)
        ay = ay + on_n * self.accel_sigma * self._normal(n)
        ax = ax + on_b * self.accel_bias
        omega = theta_dot + on_b * self.bias + on_n * self.gyro_sigma * self._normal(n)
        return ax, ay, omega


class TiltFilter:
    """Fusion of accelerometer tilt (2.39) and gyro rate (2.40) into ``theta, theta'``."""

    def __init__(self, spec: FusionSpec = FusionSpec()) -> None:
        self.spec = spec
        self.tau: Any = spec.tau  # a float, or (N,) per row (a batch of twins)
        self.x = np.zeros((0, 2))
        self.P = np.eye(2)

    def reset(self, angle_acc: NDArray[np.float64]) -> None:
        """Start from the accelerometer tilt (the robot is at rest at power-on)."""
        self.x = np.column_stack([angle_acc, np.zeros_like(angle_acc)])
        self.P = np.diag([self.spec.r_angle, 0.02**2])

    def update(
        self, omega: NDArray[np.float64], angle_acc: NDArray[np.float64], Ts: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Advance one sample; returns ``(theta, theta')`` estimates."""
        if self.spec.kind == "complementary":
            self.x[:, 0] = complementary_step(self.x[:, 0], omega, angle_acc, Ts, self.tau)
            return self.x[:, 0].copy(), np.asarray(omega, dtype=float).copy()
        self.x, self.P = kalman_step(self.x, self.P, omega, angle_acc, Ts, self.spec)
        return self.x[:, 0].copy(), np.asarray(omega, dtype=float) - self.x[:, 1]


_MEMS = "MEMS class, the book names no part"

#: The IMU's and the fusion's unknowns (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("imu.gyro_bias", -0.02, 0.02, "rad/s", _MEMS, "imu_bias", 0.01),
    Unknown("imu.accel_bias", -0.05, 0.05, "m/s^2", _MEMS, "imu_bias", 0.02),
    Unknown("imu.accel_sigma", 0.01, 0.1, "m/s^2", _MEMS, "imu_noise", 0.05),
    Unknown("imu.gyro_sigma", 0.0005, 0.005, "rad/s", _MEMS, "imu_noise", 0.002),
    Unknown("imu.height", 0.0, 0.13, "m", "board on the body, axle to top of body 2l = 0.12 m",
            "accel_motion", 0.1),
    Unknown("fusion.tau", 0.1, 2.0, "s", "complementary filter time constant, not printed",
            "fusion", 0.5),
)  # fmt: skip
