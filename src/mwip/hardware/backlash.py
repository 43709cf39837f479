"""Gearbox backlash (element ``backlash``): a play of ``gearbox.backlash`` rad at the wheel.

Per wheel, the state is the gap ``g`` (motor side minus wheel side, in ``[-width/2,
width/2]``) and its rate ``v``. In contact (``g`` at the wall the torque pushes towards) the
torque passes. Otherwise the motor side, inertia ``J_m = N^2 J`` at the wheel, moves freely,
``g'' = tau / J_m`` (the wheel's own motion and the impact are neglected), and the torque
passes from the instant ``t_c`` it closes the gap (the first root in ``[0, Ts]`` of
``g + v t + a t^2 / 2 = wall``): the held torque is ``tau (Ts - t_c) / Ts``. A run starts in
contact on the positive side with the play at rest.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.hardware.numerics import clip, maximum, minimum, sign
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["ELEMENT", "step", "CODE"]

#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 8

PARAMS = Layout((
    Field("half", (), "half the play (rad; 0 where the switch is off)"),
    Field("inertia", (), "the motor side's inertia at the wheel N^2 J (kg m^2)"),
    Field("Ts", (), "sample period (s)"),
))  # fmt: skip
STATE = Layout((Field("gap", (2,), "g (rad)"), Field("rate", (2,), "g' (rad/s)")))
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    gr: Any = ctx.value("drive.gear_ratio")
    width = ctx.on("backlash") * ctx.value("gearbox.backlash")
    return {"half": width / 2.0, "inertia": gr * gr * ctx.twin.motor.rotor_inertia,
            "Ts": ctx.twin.Ts}  # fmt: skip


def _init(ctx: PackContext) -> dict[str, Any]:
    half = ctx.rows(ctx.on("backlash") * ctx.value("gearbox.backlash")) / 2.0
    return {"gap": np.column_stack([half, half])}



@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The torque each wheel gets through the play (module docstring)."""
    Ts, half = p[P.Ts], p[P.half]
    for w in range(2):
        tau = bus[B.u + w]
        g, v = s[S.gap + w], s[S.rate + w]
        sg = sign(tau)
        if sg != 0:
            wall = sg * half
        else:
            wall = half if v >= 0 else -half
        contact = (half <= 0) or ((sg != 0) and (abs(g - wall) <= 1e-15))
        a = tau / p[P.inertia]
        d = wall - g
        disc = v * v + 2.0 * a * d
        if abs(a) > 0:
            t_c = (-v + sign(a) * math.sqrt(maximum(disc, 0.0))) / a if disc >= 0 else math.inf
        else:
            t_c = d / v if v != 0 else math.inf
        if not (math.isfinite(t_c) and t_c >= 0):
            t_c = math.inf
        closes = (not contact) and (t_c <= Ts)
        if contact:
            out = tau
        elif closes:
            out = tau * (Ts - minimum(t_c, Ts)) / Ts
        else:
            out = 0.0
        if contact or closes:
            s[S.gap + w] = wall
            s[S.rate + w] = 0.0
        else:
            s[S.gap + w] = clip(g + v * Ts + 0.5 * a * Ts * Ts, -half, half)
            s[S.rate + w] = v + a * Ts
        bus[B.u + w] = out


ELEMENT = Element(
    name="backlash", code=CODE, stage="drive", place=60, params=PARAMS, state=STATE, pack=_pack,
    init=_init, switches=("backlash",), doc="gearbox backlash",
)  # fmt: skip
