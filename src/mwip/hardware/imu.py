"""The inertial measurement unit (Sec. 2.5.1): accelerometer and gyro on the body.

Accelerometer (2.37)-(2.39)
    A two-axis accelerometer fixed to the body at ``height`` above the axle measures the
    specific force (acceleration minus gravity) in body axes: ``x`` across the body (forward
    when upright), ``y`` along it (up). Static, ``a_x = g sin(theta)``, ``a_y = g cos(theta)``
    and the tilt follows from (2.37) ``arcsin(a_x / g)`` or (2.39) ``arctan(a_x / a_y)``.
    Moving, the body's own acceleration corrupts both axes (the book's remark after (2.40)):
    the sensor point is at ``(x_w + h sin theta, h cos theta)``; with the axle's forward
    acceleration ``x'' = r psi''`` its acceleration is ``(x'' + h (theta'' cos - theta'^2
    sin), -h (theta'' sin + theta'^2 cos))``; the specific force ``f = a + (0, g)`` projected
    on the body axes gives ``a_x = f_z sin theta - f_x cos theta``, ``a_y = f_z cos theta +
    f_x sin theta`` (yaw-rate centripetal terms neglected). The body's acceleration is the
    mean over the last sample from the true velocities, ``(q'_k - q'_{k-1}) / Ts`` (the
    IMU's anti-alias / digital low-pass filter at about the sample rate delivers that, not the
    instantaneous acceleration, which jumps with every torque step).
Gyroscope (2.40)
    ``omega* = theta' + b(t) + n``: white noise ``n`` and a zero drift ``b(t)``, starting at
    ``gyro_bias`` and walking by ``gyro_bias_walk sqrt(Ts)`` per sample ("zero drift ...
    related to environmental temperature", Sec. 2.5.1). Integrated alone by (2.40) it drifts
    by ``b t``.

The element (:data:`ELEMENT`, kernel :func:`step`) draws four normal variates per sample
(bias walk, accelerometer x and y, gyro), whatever is switched on, so switching an effect off
leaves the others' noise unchanged; switches ``imu_noise`` (white noise), ``imu_bias``
(offsets and drift) and ``accel_motion`` (the body's own acceleration). It writes ``acc``,
``gyro``, ``gyro_bias`` and ``theta_acc`` (2.39) on the bus. The fusion of these into the
pitch estimate is the firmware's (:mod:`mwip.hardware.fusion`).

Noise levels (:class:`ImuNoise`) default to a consumer MEMS IMU of the robot's class
(MPU-6050 / ADXL-class data sheets, about 100 Hz bandwidth): see docs/twin.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.hardware.unknown import Unknown
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["ImuNoise", "G", "ELEMENT", "step", "UNKNOWNS", "CODE"]

#: Gravitational acceleration the accelerometer feels (m/s^2; SPEC.md section 2).
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



#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 1

PARAMS = Layout((
    Field("Ts", (), "sample period (s)"),
    Field("r", (), "wheel radius (m): the axle's acceleration r psi''"),
    Field("walk", (), "gyro_bias_walk sqrt(Ts): the drift's step (rad/s)"),
    Field("on_noise", (), "1: white noise (imu_noise)"),
    Field("on_bias", (), "1: offsets and drift (imu_bias)"),
    Field("on_motion", (), "1: the body's acceleration (accel_motion)"),
    Field("accel_sigma", (), "m/s^2"),
    Field("accel_bias", (), "m/s^2"),
    Field("gyro_sigma", (), "rad/s"),
    Field("height", (), "accelerometer above the axle (m)"),
    Field("g", (), "gravity (m/s^2)"),
))  # fmt: skip
STATE = Layout((
    Field("prev", (8,), "the true state of the previous sample"),
    Field("bias", (), "the gyro's zero drift (rad/s)"),
))  # fmt: skip
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    nz = ctx.twin.imu
    return {
        "Ts": ctx.twin.Ts, "r": ctx.rows(ctx.plant.r),
        "walk": nz.gyro_bias_walk * np.sqrt(ctx.twin.Ts),
        "on_noise": ctx.on("imu_noise"), "on_bias": ctx.on("imu_bias"),
        "on_motion": ctx.on("accel_motion"), "accel_sigma": ctx.value("imu.accel_sigma"),
        "accel_bias": ctx.value("imu.accel_bias"), "gyro_sigma": ctx.value("imu.gyro_sigma"),
        "height": ctx.value("imu.height"), "g": G,
    }  # fmt: skip


def _init(ctx: PackContext) -> dict[str, Any]:
    return {"bias": ctx.rows(ctx.value("imu.gyro_bias"))}


@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """One IMU reading (module docstring): the specific force at the sensor (2.37)-(2.39),
    the gyro (2.40), the tilt ``arctan2(a_x, a_y)`` (2.39)."""
    Ts = p[P.Ts]
    if k == 0:  # at rest in the filter's sense: no acceleration known, no drift yet
        acc0 = 0.0
        acc1 = 0.0
        bias = s[S.bias]
    else:
        acc0 = (yi[3] - s[S.prev + 3]) / Ts
        acc1 = (yi[4] - s[S.prev + 4]) / Ts
        bias = s[S.bias] + p[P.walk] * z[0]
        s[S.bias] = bias
    on_n, on_b, on_m = p[P.on_noise], p[P.on_bias], p[P.on_motion]
    th = yi[1]
    td = on_m * yi[4]
    tdd = on_m * acc1
    xdd = on_m * (p[P.r] * acc0)
    height = p[P.height]
    sn, cs = math.sin(th), math.cos(th)
    fx = xdd + height * (tdd * cs - td * td * sn)
    fz = p[P.g] - height * (tdd * sn + td * td * cs)
    ax = fz * sn - fx * cs
    ay = fz * cs + fx * sn
    ax = ax + on_n * p[P.accel_sigma] * z[1]
    ay = ay + on_n * p[P.accel_sigma] * z[2]
    ax = ax + on_b * p[P.accel_bias]
    omega = yi[4] + on_b * bias + on_n * p[P.gyro_sigma] * z[3]
    th_acc = math.atan2(ax, ay)  # (2.39)
    for j in range(8):
        s[S.prev + j] = yi[j]
    bus[B.acc] = ax
    bus[B.acc + 1] = ay
    bus[B.gyro] = omega
    bus[B.gyro_bias] = on_b * bias
    bus[B.theta_acc] = th_acc
    lg[0] = th_acc
    lg[1] = omega
    lg[2] = bias
    lg[3] = ax
    lg[4] = ay


ELEMENT = Element(
    name="imu", code=CODE, stage="sensor", place=10, params=PARAMS, state=STATE, pack=_pack,
    init=_init,
    logs=(("imu_theta_acc", 1), ("imu_gyro", 1), ("imu_gyro_bias", 1), ("imu_accel", 2)),
    noise=4,
    switches=("fusion", "accel_motion", "imu_noise", "imu_bias"),
    doc="accelerometer and gyro with noise, offsets and drift",
)  # fmt: skip

_MEMS = "MEMS class, the book names no part"

#: The IMU's unknowns (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("imu.gyro_bias", -0.02, 0.02, "rad/s", _MEMS, "imu_bias", 0.01),
    Unknown("imu.accel_bias", -0.05, 0.05, "m/s^2", _MEMS, "imu_bias", 0.02),
    Unknown("imu.accel_sigma", 0.01, 0.1, "m/s^2", _MEMS, "imu_noise", 0.05),
    Unknown("imu.gyro_sigma", 0.0005, 0.005, "rad/s", _MEMS, "imu_noise", 0.002),
    Unknown("imu.height", 0.0, 0.13, "m", "board on the body, axle to top of body 2l = 0.12 m",
            "accel_motion", 0.1),
)  # fmt: skip
