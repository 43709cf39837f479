"""The board's pitch estimate: power-on gyro zeroing and the fusion filter (firmware).

What the board does with its IMU (:mod:`mwip.hardware.imu`) is the firmware's, and decides
whether the pitch estimate carries a constant offset (docs/twin_model.md):

Gyro zeroing (``firmware.gyro_zeroing``)
    At power-on, the robot at rest, the firmware averages the gyro and subtracts that offset
    from every later reading. Over a rest of ``N`` samples the estimate's noise
    ``gyro_sigma / sqrt(N)`` (below 2e-4 rad/s for ``N >= 100``) is neglected: the offset
    removed is the gyro's offset at power-on; its drift after that remains.
Complementary filter (``kind = "complementary"``, Sec. 2.5.1)
    ``theta = a (theta + omega* Ts) + (1 - a) theta_acc``, ``a = tau / (tau + Ts)``: the gyro
    path is the integration (2.40), the accelerometer tilt (2.39) corrects its drift below
    ``1 / tau`` rad/s; ``theta'`` is the gyro's reading. A constant gyro offset ``b`` leaves
    a steady error ``b tau``.
Kalman filter (``kind = "kalman"``, Sec. 2.5.1)
    State ``[theta, b]``, the gyro as input, the accelerometer tilt as measurement:
    ``theta^- = theta + (omega* - b) Ts``, ``P^- = A P A^T + Q`` with ``A = [[1, -Ts], [0,
    1]]``, ``Q = diag(q_angle, q_bias) Ts``; gain ``K = P^-[:, 0] / (P^-_00 + r_angle)``;
    ``theta' = omega* - b``. It estimates and removes the gyro's offset. Its tuning is the
    :class:`FusionSpec`'s, or per robot where the twin's prior has ``firmware.fusion.q_angle``
    / ``q_bias`` / ``r_angle`` as unknowns (structure S3 of the book calibration,
    :mod:`mwip.calibration.structures`).

Both start from the accelerometer tilt at power-on (the robot at rest); the Kalman
covariance from ``diag(r_angle, 0.02^2)``. The element (:data:`ELEMENT`, kernel
:func:`step`; switch ``fusion``: without it the board reads the true pitch and rate) writes
``theta_hat``, ``rate_hat`` and the measurement's pitch and rate on the bus.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["FusionSpec", "ELEMENT", "step", "P0_BIAS", "CODE"]

#: Initial standard deviation of the Kalman filter's gyro-offset estimate (rad/s).
P0_BIAS = 0.02


def _check(
    name: str, value: float, lo: float, hi: float = np.inf, *, open_lo: bool = False
) -> None:
    ok = np.isfinite(value) and (value > lo if open_lo else value >= lo) and value <= hi
    if not ok:
        left = "(" if open_lo else "["
        raise ValueError(f"{name!r} must be finite and in {left}{lo:g}, {hi:g}], got {value!r}")


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



#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 2

PARAMS = Layout((
    Field("Ts", (), "sample period (s)"),
    Field("kalman", (), "0: complementary, 1: Kalman"),
    Field("on", (), "1: the estimate comes from the filter (switch fusion)"),
    Field("zeroing", (), "1: the gyro's offset at power-on is subtracted"),
    Field("a", (), "complementary: tau / (tau + Ts)"),
    Field("one_minus_a", (), "complementary: 1 - a"),
    Field("q_angle", (), "Kalman: q_angle Ts (rad^2)"),
    Field("q_bias", (), "Kalman: q_bias Ts (rad^2/s^2)"),
    Field("r_angle", (), "Kalman: tilt variance (rad^2)"),
    Field("p0_bias", (), "Kalman: initial offset variance (rad^2/s^2)"),
))  # fmt: skip
STATE = Layout((
    Field("angle", (), "filter angle (rad)"),
    Field("bias", (), "Kalman: gyro offset estimate (rad/s)"),
    Field("cov", (2, 2), "Kalman: covariance"),
    Field("offset", (), "gyro offset removed at power-on (rad/s)"),
))  # fmt: skip
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    fw = ctx.twin.firmware
    spec = fw.fusion
    Ts = fw.Ts
    tau: Any = ctx.value("firmware.fusion.tau")
    a = tau / (tau + Ts)  # the same NumPy expression per row

    def tuning(name: str) -> Any:  # per row where the twin's prior has it (a structure's)
        return ctx.value(f"firmware.fusion.{name}")

    return {
        "Ts": Ts, "kalman": float(spec.kind == "kalman"), "on": ctx.on("fusion"),
        "zeroing": float(fw.gyro_zeroing), "a": a, "one_minus_a": 1.0 - a,
        "q_angle": tuning("q_angle") * Ts, "q_bias": tuning("q_bias") * Ts,
        "r_angle": tuning("r_angle"), "p0_bias": P0_BIAS**2,
    }  # fmt: skip


@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The pitch estimate of one sample (module docstring)."""
    omega = bus[B.gyro]
    th_acc = bus[B.theta_acc]
    if p[P.zeroing] != 0.0:
        if k == 0:
            s[S.offset] = bus[B.gyro_bias]
        omega = omega - s[S.offset]
    if k == 0:  # power-on: start from the accelerometer tilt
        s[S.angle] = th_acc
        s[S.bias] = 0.0
        s[S.cov] = p[P.r_angle]
        s[S.cov + 1] = 0.0
        s[S.cov + 2] = 0.0
        s[S.cov + 3] = p[P.p0_bias]
        th_hat, thd_hat = th_acc, omega
    elif p[P.kalman] == 0.0:
        x0 = p[P.a] * (s[S.angle] + omega * p[P.Ts]) + p[P.one_minus_a] * th_acc
        s[S.angle] = x0
        th_hat, thd_hat = x0, omega
    else:
        Ts = p[P.Ts]
        x0, x1 = s[S.angle], s[S.bias]
        p00, p01, p10, p11 = s[S.cov], s[S.cov + 1], s[S.cov + 2], s[S.cov + 3]
        xp0 = x0 + (omega - x1) * Ts
        # P^- = A P A^T + Q, A = [[1, -Ts], [0, 1]]
        a00 = p00 - Ts * p10
        a01 = p01 - Ts * p11
        q00 = a00 - Ts * a01 + p[P.q_angle]
        q01 = a01
        q10 = p10 - Ts * p11
        q11 = p11 + p[P.q_bias]
        den = q00 + p[P.r_angle]
        k0 = q00 / den
        k1 = q10 / den
        innov = th_acc - xp0
        x0 = xp0 + innov * k0
        x1 = x1 + innov * k1
        n00 = q00 - k0 * q00
        n01 = q01 - k0 * q01
        n10 = q10 - k1 * q00
        n11 = q11 - k1 * q01
        s[S.angle], s[S.bias] = x0, x1
        s[S.cov] = n00
        s[S.cov + 1] = 0.5 * (n01 + n10)
        s[S.cov + 2] = 0.5 * (n10 + n01)
        s[S.cov + 3] = n11
        th_hat, thd_hat = x0, omega - x1
    if p[P.on] == 0.0:
        th_hat, thd_hat = yi[1], yi[4]
    bus[B.theta_hat] = th_hat
    bus[B.rate_hat] = thd_hat
    bus[B.ym + 1] = th_hat
    bus[B.ym + 4] = thd_hat


ELEMENT = Element(
    name="fusion", code=CODE, stage="sensor", place=20, params=PARAMS, state=STATE, pack=_pack,
    switches=("fusion", "accel_motion", "imu_noise", "imu_bias"),
    doc="the board's pitch estimate: gyro zeroing, complementary or Kalman fusion",
)  # fmt: skip
