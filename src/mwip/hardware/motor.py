"""DC motor (MAXON RE25, Table 2.1) and PWM driver (Sec. 2.5.2) as the robot's actuator.

Motor, per wheel (armature circuit and shaft)::

    L i' = V - R i - k_e omega_m,      tau_m = k_t i,      J_r omega_m' = tau_m - tau_load

Table 2.1 prints no resistance or constants; they follow from its numbers so that the table
is reproduced exactly at the rated 24 V (tested): ``k_e = V / omega_0`` (no-load speed
9560 rpm), ``k_t = k_e`` (SI), ``R = k_t V / tau_stall`` (stall torque 243 mN m; SPEC.md
section 3: the table's "N m" are mN m). That gives ``k_t = 23.97 mN m/A`` and
``R = 2.37 Ohm``, within 3 % of MAXON's catalogue RE25 24 V (118752: 23.4 mN m/A,
2.32 Ohm). Inductance 0.238 mH (catalogue; Table 2.1 has none).

Gearbox: ratio ``N = 23`` (MAXON GP 32 A, 23:1, a standard pairing with the RE25); wheel
torque ``N eta k_t i``, motor speed ``N (psi_i' - theta')`` (the stator is on the body).
Why 23 (docs/twin.md): wheel stall torque 5.6 N m and continuous 0.60 N m per wheel cover the
0.1-0.5 N m the Chapter 6 controllers command (Figs. 6.4-6.16 plot |tau| <= 0.2 N m;
transients reach ~1 N m), while the wheel no-load speed 43.5 rad/s leaves ample headroom over
the 7 rad/s speed target.

Driver (Sec. 2.5.2: a MOSFET H-bridge, "the PWM technique is used to realize speed
regulation"): it takes the firmware's duty command (:mod:`mwip.hardware.firmware`: in a
voltage drive, ``mode="voltage"``, the duty follows the torque command open-loop, so back-EMF
acts on the motor as the physical damping ``eta N^2 k_t k_e / R`` per wheel, 0.096 N m s/rad;
``mode="torque"`` is a current-mode servo driver, ``V* = R i* + k_e omega_m``). Then, as the
hardware does it (element :data:`ELEMENT`, kernel :func:`step`): duty clipped to [-1, 1]
against the nominal 24 V, quantised to ``pwm_levels`` and reduced by the dead-band (switch
``pwm``), times the battery voltage sagging under the current drawn the sample before
(switch ``sag``), and the driver's current limit ``|V - k_e omega_m| <= R I_max`` within the
supply. The current is integrated exactly over the sample (``V``, ``omega_m`` held):
``i_end = i_ss + (i_0 - i_ss) e^{-Ts/tau_e}``, ``i_ss = (V - k_e omega_m) / R``, and the torque
held over the sample is the one produced by the *mean* current,
``i_mean = i_ss + (i_0 - i_ss) (tau_e / Ts)(1 - e^{-Ts/tau_e})``.

The data sheet and the drive's specification (:class:`MotorData`, :data:`RE25`,
:class:`DriveSpec`) are plain values in :mod:`mwip.hardware.motor_data`, re-exported here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.hardware.motor_data import RE25, RPM, DriveSpec, MotorData
from mwip.hardware.numerics import clip, maximum, sign
from mwip.hardware.unknown import Unknown
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["MotorData", "RE25", "RPM", "DriveSpec", "ELEMENT", "step", "UNKNOWNS", "CODE"]

#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 6

PARAMS = Layout((
    Field("R", (), "winding resistance (Ohm)"),
    Field("gain", (), "wheel torque per ampere N eta k_t (N m/A)"),
    Field("gear_ratio", (), "motor turns per wheel turn"),
    Field("b_over_r", (), "b / r"),
    Field("k_e", (), "back-EMF constant (V s/rad)"),
    Field("V", (), "nominal supply voltage (V)"),
    Field("levels", (), "duty steps (0: not quantised)"),
    Field("deadband", (), "duty lost to the bridge's dead time"),
    Field("pwm", (), "1: quantisation and dead-band (switch pwm)"),
    Field("sag", (), "1: battery sag (switch sag)"),
    Field("R_s", (), "battery + wiring resistance (Ohm)"),
    Field("band", (), "R I_max: the current limit as a voltage band (V)"),
    Field("decay", (), "exp(-Ts / tau_e)"),
    Field("tau_over_Ts", (), "tau_e / Ts"),
    Field("emf_in_plant", (), "1: the plant integrates the back-EMF damping itself"),
    Field("on", (), "1: the wheels get the motor's torque (switch motor)"),
))  # fmt: skip
STATE = Layout((
    Field("i", (2,), "motor currents at the sample's end (A)"),
    Field("i_bat", (), "battery current of the last sample (A)"),
))  # fmt: skip
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    m, d = ctx.twin.motor, ctx.twin.drive
    gr: Any = ctx.value("drive.gear_ratio")
    R = m.resistance
    Ts = ctx.twin.Ts
    return {
        "R": R, "gain": np.asarray(gr, dtype=float) * d.gear_efficiency * m.k_t,
        "gear_ratio": gr, "b_over_r": np.asarray(ctx.plant.b / ctx.plant.r, dtype=float),
        "k_e": m.k_e, "V": d.supply_voltage, "levels": float(d.pwm_levels),
        "deadband": ctx.value("drive.deadband"), "pwm": ctx.on("pwm"), "sag": ctx.on("sag"),
        "R_s": d.supply_resistance,
        "band": R * np.asarray(ctx.value("drive.current_limit"), dtype=float),
        "decay": np.exp(-Ts / m.tau_e),  # NumPy's exp, computed once
        "tau_over_Ts": m.tau_e / Ts, "emf_in_plant": float(d.mode == "voltage"),
        "on": ctx.on("motor"),
    }  # fmt: skip






@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The driver and motors of one sample (module docstring): the firmware's duty on the bus
    in, the wheel torques out (where the switch ``motor`` is on); logs ``drive_duty``,
    ``drive_current`` (mean), ``drive_voltage``, ``drive_supply``, ``drive_torque`` (the whole
    motor torque) and ``drive_limited``."""
    pd, td, ad = yi[3], yi[4], yi[5]
    bor = p[P.b_over_r]
    R, gain, V = p[P.R], p[P.gain], p[P.V]
    vs = V - (p[P.R_s] * s[S.i_bat] if p[P.sag] != 0.0 else 0.0)
    vs = maximum(vs, 0.0)
    p0 = 0.0
    for w in range(2):
        wheel = pd + bor * ad - td if w == 0 else pd - bor * ad - td
        om = p[P.gear_ratio] * wheel
        emf = p[P.k_e] * om
        duty_ref = bus[B.duty + w]
        duty = clip(duty_ref, -1.0, 1.0)
        if p[P.pwm] != 0.0:
            shaped = duty
            if p[P.levels] > 0.0:
                shaped = np.round(shaped * p[P.levels]) / p[P.levels]
            duty = sign(shaped) * maximum(abs(shaped) - p[P.deadband], 0.0)
        v = duty * vs
        band = p[P.band]
        v_lim = clip(clip(v, emf - band, emf + band), -vs, vs)
        i_ss = (v_lim - p[P.k_e] * om) / R
        dev = s[S.i + w] - i_ss
        e = p[P.decay]
        s[S.i + w] = i_ss + dev * e
        i_mean = i_ss + dev * p[P.tau_over_Ts] * (1.0 - e)
        duty_eff = v_lim / vs if vs > 0 else 0.0
        torque = gain * i_mean
        out = torque + gain * emf / R if p[P.emf_in_plant] != 0.0 else torque
        if w == 0:
            p0 = duty_eff * i_mean
        else:
            s[S.i_bat] = p0 + duty_eff * i_mean
        if p[P.on] != 0.0:
            bus[B.u + w] = out
        lg[w] = duty_eff
        lg[2 + w] = i_mean
        lg[4 + w] = v_lim
        lg[7 + w] = torque
        lg[9 + w] = 1.0 if (abs(duty_ref) > 1.0 or abs(v_lim - v) > 1e-12) else 0.0
    lg[6] = vs


ELEMENT = Element(
    name="motor", code=CODE, stage="drive", place=40, params=PARAMS, state=STATE, pack=_pack,
    logs=(("drive_duty", 2), ("drive_current", 2), ("drive_voltage", 2), ("drive_supply", 1),
          ("drive_torque", 2), ("drive_limited", 2)),
    switches=("motor",), doc="DC motors and H-bridge PWM driver",
)  # fmt: skip

#: The drive's unknowns (docs/twin_model.md, "The prior"); Table 2.1's motor data, the 24 V
#: battery and the encoder lines are fixed by the data sheet.
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("drive.gear_ratio", 3.7, 51.0, "", "MAXON GP 32 A planetary ratios offered with "
            "the RE25, 1-3 stages; the book names no gearbox", "inertia", 23.0),
    Unknown("drive.deadband", 0.0, 0.05, "duty", "H-bridge dead time / minimum pulse, "
            "0-2.5 us at 20 kHz", "pwm", 0.01),
    Unknown("drive.current_limit", 1.0, 10.0, "A", "RE25 continuous current to its stall "
            "current at 24 V, Table 2.1", "motor", 4.0),
)  # fmt: skip
