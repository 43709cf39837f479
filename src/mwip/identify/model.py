"""Prediction models of the fit: pure functions over arrays, leading batch axis = segments.

Wheels-off-ground (the robot on a stand: body fixed, each wheel free) per wheel and sample
``k`` (docs/twin_fit.md), the twin's drive chain (:class:`mwip.hardware.twin.TwinActuator`,
the elements of :data:`mwip.hardware.registry.DRIVE_CHAIN` in their order) written
batch-first:

1. delay (:mod:`mwip.hardware.delay`, on the command, before the firmware): the duty command
   ``d_k`` (logged, or ``k R u_k / (N eta k_t V_0)`` from a torque command, ``k`` the
   firmware's torque gain of the robot file) held as
   ``D d_{k-1} + (1 - D) d_k``;
2. the firmware (:mod:`mwip.hardware.firmware`) adds the back-EMF compensation
   ``c k_e omega_m / V_0`` of the speed at the sample (``omega_m = N w_k``); the driver
   (:mod:`mwip.hardware.motor`) clips to [-1, 1] and takes the dead-band
   ``sign(d) max(|d| - db, 0)`` (smooth: ``sp(d - db) - sp(-d - db)``, ``sp`` the softplus of
   width :data:`DEADBAND_WIDTH`);
3. the battery ``V_s = V_0 - R_s I_bat`` (previous sample), the current limit
   ``|V - k_e omega_m| <= R I_max`` and the supply ``|V| <= V_s``;
4. the current integrated exactly over the sample (inductance), the torque of the mean
   current ``eta N k_t i_mean`` plus the held part of the back-EMF ``eta N k_t k_e omega_m / R``;
5. Coulomb friction in the discrete stick-slip form of
   :mod:`mwip.hardware.friction` (the sliding ``sign`` smoothed by
   ``tanh(x / COULOMB_WIDTH)``), mobility ``1 / J``, ``J = I_wa + N^2 J_rotor``;
6. ``J w' = T - (c_emf + b_v + D_b) w`` integrated exactly over the sample
   (``c_emf = eta N^2 k_t k_e / R``, the back-EMF's continuous viscous torque).

PWM quantisation (``pwm_levels`` of the base twin) is applied as the twin does (``round``), or
its errors along a trajectory are held (``qerr``): the smooth model with the quantised one's
errors, which the fit's second stage iterates to a fixed point (:mod:`mwip.identify.fit`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Known", "STAND_PARAMS", "DEADBAND_WIDTH", "COULOMB_WIDTH", "stand_rollout"]

#: Softplus width of the smooth dead-band (duty).
DEADBAND_WIDTH = 1e-4
#: tanh width of the smooth Coulomb sign (rad/s of wheel speed).
COULOMB_WIDTH = 1e-3

#: The parameters the wheels-off-ground model depends on.
STAND_PARAMS: tuple[str, ...] = (
    "drive.gear_ratio", "firmware.emf_compensation", "drive.deadband", "drive.current_limit",
    "gearbox.coulomb", "gearbox.viscous", "firmware.delay",
)  # fmt: skip


@dataclass(frozen=True)
class Known:
    """The constants the fit takes from the base twin (motor data, battery, wheel)."""

    Ts: float
    R: float
    tau_e: float
    ke: float
    eta: float
    Vs: float
    Rs: float
    Iwa: float
    Jr: float
    Db: float
    pwm_levels: int = 0
    #: the firmware's torque gain ``k`` (:mod:`mwip.hardware.firmware`): a torque command
    #: ``u`` is the duty ``k R u / (N eta k_t V_0)``
    torque_gain: float = 1.0

    @classmethod
    def from_twin(cls, twin: object, Ts: float, body: object | None = None) -> Known:
        """The constants of ``twin`` at sample period ``Ts``, the wheel's inertia ``Iwa`` and
        the viscous ``Db`` from the robot's ``body`` (its :class:`mwip.params.Params`;
        default Table 6.1)."""
        from mwip.params import REAL

        b = REAL if body is None else body
        m = twin.motor  # type: ignore[attr-defined]
        d = twin.drive  # type: ignore[attr-defined]
        sag = "sag" in twin.active  # type: ignore[attr-defined]
        return cls(Ts=float(Ts), R=m.resistance, tau_e=m.tau_e, ke=m.k_e,
                   eta=d.gear_efficiency, Vs=d.supply_voltage,
                   Rs=d.supply_resistance if sag else 0.0, Iwa=float(b.Iwa),  # type: ignore[attr-defined]
                   Jr=m.rotor_inertia, Db=float(b.Db),  # type: ignore[attr-defined]
                   pwm_levels=int(d.pwm_levels) if "pwm" in twin.active else 0,  # type: ignore[attr-defined]
                   torque_gain=float(twin.firmware.torque_gain))  # type: ignore[attr-defined]  # fmt: skip


def _softplus(x: NDArray[np.float64], w: float) -> NDArray[np.float64]:
    return w * np.logaddexp(0.0, x / w)


def deadband(d: NDArray[np.float64], db: Any, width: float) -> NDArray[np.float64]:
    """Smooth ``sign(d) max(|d| - db, 0)`` (exact for ``width = 0``)."""
    if width <= 0:
        return np.sign(d) * np.maximum(np.abs(d) - db, 0.0)
    return _softplus(d - db, width) - _softplus(-d - db, width)


def karnopp(w: NDArray[np.float64], drive: NDArray[np.float64], fc: Any, mob: Any,
            Ts: float, width: float) -> NDArray[np.float64]:  # fmt: skip
    """Coulomb friction held over the sample (stick-slip form, smooth sliding sign)."""
    need = -w / (Ts * mob) - drive
    x = w + Ts * mob * drive
    sgn = np.tanh(x / width) if width > 0 else np.sign(x)
    return np.where(np.abs(need) <= fc, need, -fc * sgn)


def _col(v: object) -> float | NDArray[np.float64]:
    """A parameter as a float, or one per segment as an (S, 1) column."""
    return float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float).reshape(-1, 1)  # type: ignore[arg-type]


def stand_rollout(
    p: Mapping[str, float | NDArray[np.float64]],
    cmd: NDArray[np.float64],
    is_duty: NDArray[np.bool_],
    w0: NDArray[np.float64],
    k: Known,
    widths: tuple[float, float] = (DEADBAND_WIDTH, COULOMB_WIDTH),
    w_prev: NDArray[np.float64] | None = None,
    cmd_prev2: NDArray[np.float64] | None = None,
    qerr: NDArray[np.float64] | None = None,
    qerr_out: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Wheel angles (relative to the start) and speeds over segments, both (S, L, 2).

    ``cmd`` (S, L + 1, 2): the command of the sample before each segment (0 at a log's start),
    then the segment's: duties where ``is_duty`` (S,) else wheel torques (N m); ``w0`` (S, 2)
    the wheel speeds at the segments' first samples. Each parameter of ``p`` is a number or
    one per segment (S,) (a batch of parameter sets in one call).

    The state a segment starts from is more than ``w0``: the current and battery load at the
    start are the steady ones of the voltage held over the sample before, the delay's mix
    ``D d_{-2} + (1 - D) d_{-1}`` (``cmd_prev2`` (S, 2), the command two samples before;
    default ``cmd[:, 0]``) plus the back-EMF compensation ``c k_e N w_{-1} / V_0`` of the
    speed ``w_prev`` (S, 2) of the sample before (default ``w0``; the current's transient
    carries over only ``f = (tau_e / Ts)(1 - e^{-Ts/tau_e})`` of it). The delay mixes the
    commands before the firmware compensates, as the twin's chain does: the first sample's
    duty holds the compensation of ``w0`` only (an earlier model delayed the compensated
    duty, ``D c k_e N w_{-1} / V_0`` on the first sample and one sample late after, and
    covered the truth's 2-sigma intervals 168 times of 200; docs/twin_fit.md).

    PWM quantisation: with ``k.pwm_levels`` the clipped duty of each sample (index 0: the one
    held before the segment) is rounded as the twin does, and ``qerr_out`` (S, L, 2), if
    given, receives the rounding errors ``q(d) - d``; with ``qerr`` (S, L, 2) those errors are
    added instead, held (a smooth model that reproduces the quantised one where its errors
    are those of the trajectory; :mod:`mwip.identify.fit`, stage 2).
    """
    N = _col(p["drive.gear_ratio"])
    c = _col(p["firmware.emf_compensation"])
    db = _col(p["drive.deadband"])
    imax = _col(p["drive.current_limit"])
    fc = _col(p["gearbox.coulomb"])
    bv = _col(p["gearbox.viscous"])
    dl = _col(p["firmware.delay"])
    S, L1, _ = cmd.shape
    L = L1 - 1
    gain = N * k.eta * k.ke
    J = k.Iwa + N * N * k.Jr
    D = k.eta * N * N * k.ke * k.ke / k.R + bv + k.Db
    a = np.exp(-D * k.Ts / J)
    mob = 1.0 / J
    e_el = np.exp(-k.Ts / k.tau_e)
    f_el = (k.tau_e / k.Ts) * (1.0 - e_el)
    scale = np.where(is_duty[:, None], 1.0, k.torque_gain * k.R / (gain * k.Vs))
    duty_cmd = cmd * scale[:, :, None]
    band = k.R * imax
    Jd = J / D * (1.0 - a)

    def voltage(dmix: NDArray[np.float64], emf: NDArray[np.float64],
                vs: NDArray[np.float64], j: int) -> NDArray[np.float64]:  # fmt: skip
        d = np.clip(dmix, -1.0, 1.0)
        if qerr is not None:
            d = d + qerr[:, j]
        elif k.pwm_levels > 0:
            q = np.round(d * k.pwm_levels) / k.pwm_levels
            if qerr_out is not None:
                qerr_out[:, j] = q - d
            d = q
        d = deadband(d, db, widths[0])
        v = d * vs
        return np.clip(np.clip(v, emf - band, emf + band), -vs, vs)

    w = np.array(w0, dtype=float)
    emf = k.ke * N * (w if w_prev is None else np.asarray(w_prev, dtype=float))
    # the twin's order: the delay mixes the commands (mwip.hardware.delay), then the firmware
    # adds the back-EMF compensation of the speed it reads at the sample
    # (mwip.hardware.firmware)
    dprev = duty_cmd[:, 0]
    dheld = dprev if cmd_prev2 is None else dl * cmd_prev2 * scale + (1.0 - dl) * dprev
    dheld = dheld + c * emf / k.Vs
    vs0 = np.full((S, 1), k.Vs)
    v = voltage(dheld, emf, vs0, 0)
    i = (v - emf) / k.R
    ibat = np.sum(v / vs0 * i, axis=1, keepdims=True)
    phi = np.zeros((S, 2))
    out_phi = np.zeros((S, L, 2))
    out_w = np.zeros((S, L, 2))
    out_w[:, 0] = w
    for j in range(L - 1):
        emf = k.ke * N * w
        dj = duty_cmd[:, j + 1]
        dmix = dl * dprev + (1.0 - dl) * dj + c * emf / k.Vs
        dprev = dj
        vs = np.maximum(k.Vs - k.Rs * ibat, 0.0)
        v = voltage(dmix, emf, vs, j + 1)
        iss = (v - emf) / k.R
        i_mean = iss + (i - iss) * f_el
        i = iss + (i - iss) * e_el
        with np.errstate(divide="ignore", invalid="ignore"):
            ibat = np.sum(np.where(vs > 0, v / vs, 0.0) * i_mean, axis=1, keepdims=True)
        torque = gain * i_mean + gain * emf / k.R
        T = torque + karnopp(w, torque, fc, mob, k.Ts, widths[1])
        wss = T / D
        phi = phi + wss * k.Ts + (w - wss) * Jd
        w = wss + (w - wss) * a
        out_phi[:, j + 1] = phi
        out_w[:, j + 1] = w
    return out_phi, out_w
