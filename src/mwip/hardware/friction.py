"""Gearbox Coulomb friction and stiction held over a sample (element ``friction``).

Discrete stick-slip form (Karnopp): the torque that would stop the wheel's speed relative to
the body ``w`` within the sample, ``f* = -w / (Ts m) - tau`` (``m`` the relative mobility of
one wheel upright at rest, :func:`mwip.hardware.drivetrain.relative_mobility`; ``tau`` the
torque the drive delivers), is applied when ``|f*| <= F_c`` (sticking), else
``-F_c sign(w + Ts m tau)`` (sliding). A held ``-F_c sign(w)`` would instead reverse a slow
wheel within the sample and chatter at the sample rate. ``F_c = gearbox.coulomb`` per wheel.
The gearbox's viscous friction is the plant's (``Db``, :meth:`mwip.hardware.twin.Twin.plant`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.hardware.numerics import sign
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["ELEMENT", "step", "CODE"]

#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 7

PARAMS = Layout((
    Field("f_c", (), "Coulomb torque per wheel (N m; 0 where the switch is off)"),
    Field("mobility", (), "relative mobility of one wheel (1 / (kg m^2))"),
    Field("Ts", (), "sample period (s)"),
    Field("b_over_r", (), "b / r"),
    Field("gear_ratio", (), "motor turns per wheel turn"),
))  # fmt: skip
P = PARAMS.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    from mwip.hardware.drivetrain import relative_mobility

    return {"f_c": ctx.value("gearbox.coulomb") * ctx.on("friction"),
            "mobility": ctx.extra.get("mobility", relative_mobility(ctx.plant)),
            "Ts": ctx.twin.Ts, "b_over_r": np.asarray(ctx.plant.b / ctx.plant.r, dtype=float),
            "gear_ratio": ctx.value("drive.gear_ratio")}  # fmt: skip



@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """Adds each wheel's Coulomb torque to the torque on the bus; logs ``drive_friction``."""
    bor, gr = p[P.b_over_r], p[P.gear_ratio]
    pd, td, ad = yi[3], yi[4], yi[5]
    fc, m, Ts = p[P.f_c], p[P.mobility], p[P.Ts]
    for w in range(2):
        wheel = pd + bor * ad - td if w == 0 else pd - bor * ad - td
        om = gr * wheel / gr  # the motor's speed back at the wheel, as the drive reads it
        drv = bus[B.u + w]
        need = -om / (Ts * m) - drv
        fric = need if abs(need) <= fc else -fc * sign(om + Ts * m * drv)
        bus[B.u + w] = drv + fric
        lg[w] = fric


ELEMENT = Element(
    name="friction", code=CODE, stage="drive", place=50, params=PARAMS, state=Layout(), pack=_pack,
    logs=(("drive_friction", 2),), switches=("friction",),
    doc="gearbox Coulomb friction and stiction",
)  # fmt: skip
