"""The firmware's computation and actuation delay (element ``delay``).

The board samples at ``t_k = k Ts``, computes the law and writes the new duty ``d Ts`` later
(``firmware.delay = d`` in [0, 1]), so the torque command held over the sample is
``d u_{k-1} + (1 - d) u_k``: exact for ``d = 0`` and for ``d = 1`` (a one-sample shift), the
sample's mean for a fraction. The measured computation time of a law on the board's processor
(``mwip export c --pil``) sets ``d`` (docs/export.md).
"""

from __future__ import annotations

from typing import Any

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["ELEMENT", "step", "CODE"]

#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 4

PARAMS = Layout((Field("d", (), "delay as a fraction of Ts (0 where the switch is off)"),))
STATE = Layout((Field("u_prev", (2,), "the previous sample's command (N m)"),))
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    return {"d": ctx.value("firmware.delay") * ctx.on("delay")}


@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """``u <- d u_{k-1} + (1 - d) u_k`` (module docstring)."""
    d = p[P.d]
    for w in range(2):
        u = bus[B.u + w]
        bus[B.u + w] = d * s[S.u_prev + w] + (1.0 - d) * u
        s[S.u_prev + w] = u


ELEMENT = Element(
    name="delay", code=CODE, stage="drive", place=20, params=PARAMS, state=STATE, pack=_pack,
    switches=("delay", "motor", "pwm", "sag", "friction", "backlash"),
    doc="computation and actuation delay (it runs wherever the drive does: d = 0 passes)",
)  # fmt: skip
