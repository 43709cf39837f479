"""Quadrature wheel encoders (Sec. 2.5.1, HED-5540 class) and the board's odometry.

The encoder sits on the motor shaft, so it counts the rotation of the wheel *relative to the
body* through the gearbox: ``counts_i = floor(cpr * N_gear (psi_i - theta) / 2 pi)`` with
``psi_r = psi + b alpha / r``, ``psi_l = psi - b alpha / r``. The controller board recovers
``psi = mean(relative angle) + theta^ - theta^(0)`` (the fused pitch added back),
``alpha = r (psi_r - psi_l) / 2b`` and the rates by differences over the sample period ("the
number of pulses measured per unit time is the angular velocity", Sec. 2.5.1); the position
by odometry, ``x_{k+1} = x_k + Ts v cos(alpha)``, ``y_{k+1} = y_k + Ts v sin(alpha)``,
``v = r psi'``. Counters start at power-on (the first sample).

Defaults: the book's HED-5540-C06 (Fig. 2.6): in the HEDS-5540 ordering code the letter is
the resolution, ``C`` = 100 lines per turn (``A`` would be 500), and the LM3S2965's
quadrature encoder interface counts all four edges: 400 counts per motor turn, 9200 per wheel
turn behind the 23:1 gearbox (docs/twin_model.md; 2000 with 500 lines is the sensitivity).

The element (:data:`ELEMENT`, kernel :func:`step`; switch ``encoder``: without it the board
reads the true wheel angle, yaw, their rates and the position) writes the measurement's
``psi, alpha, psi', alpha', x, y`` on the bus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["EncoderSpec", "ELEMENT", "step", "CODE"]


@dataclass(frozen=True)
class EncoderSpec:
    """``cpr`` counts per motor revolution (after quadrature decoding). The encoder is on the
    motor shaft: its wheel resolution follows the gear ratio (:meth:`resolution`)."""

    cpr: int = 400

    def __post_init__(self) -> None:
        if int(self.cpr) != self.cpr or not (1 <= self.cpr <= 10_000_000):
            raise ValueError(f"'cpr' must be an integer in [1, 1e7], got {self.cpr!r}")

    def resolution(self, gear_ratio: Any) -> Any:
        """Wheel angle per count (rad) behind ``gear_ratio`` (a number or per robot)."""
        return 2.0 * np.pi / (self.cpr * gear_ratio)


#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 3

PARAMS = Layout((
    Field("Ts", (), "sample period (s)"),
    Field("r", (), "wheel radius (m)"),
    Field("b_over_r", (), "b / r"),
    Field("resolution", (), "wheel angle per count (rad)"),
    Field("on", (), "1: the encoders' readings (switch encoder)"),
))  # fmt: skip
STATE = Layout((
    Field("theta0", (), "the pitch estimate at power-on (rad)"),
    Field("c0", (2,), "the counters at power-on"),
    Field("rel", (2,), "the wheel angles relative to the body at the previous sample (rad)"),
    Field("origin", (4,), "psi, alpha, x, y at power-on"),
    Field("pos", (2,), "odometry position (m)"),
))  # fmt: skip
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    gr: Any = ctx.value("drive.gear_ratio")
    enc = ctx.twin.encoder
    res = enc.resolution(gr)
    r = np.asarray(ctx.plant.r, dtype=float)
    bor = np.asarray(ctx.plant.b / ctx.plant.r, dtype=float)
    return {"Ts": ctx.twin.Ts, "r": r, "b_over_r": bor, "resolution": res,
            "on": ctx.on("encoder")}  # fmt: skip


@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The encoders and odometry of one sample (module docstring)."""
    Ts, bor, res = p[P.Ts], p[P.b_over_r], p[P.resolution]
    th_hat, thd_hat = bus[B.theta_hat], bus[B.rate_hat]
    rel0 = yi[0] + bor * yi[2] - yi[1]
    rel1 = yi[0] - bor * yi[2] - yi[1]
    if k == 0:
        s[S.theta0] = th_hat
        s[S.c0] = math.floor(rel0 / res)
        s[S.c0 + 1] = math.floor(rel1 / res)
        s[S.origin] = yi[0]
        s[S.origin + 1] = yi[2]
        s[S.origin + 2] = yi[6]
        s[S.origin + 3] = yi[7]
        s[S.pos] = yi[6]
        s[S.pos + 1] = yi[7]
    rel0 = float(math.floor(rel0 / res) - s[S.c0]) * res
    rel1 = float(math.floor(rel1 / res) - s[S.c0 + 1]) * res
    if k == 0:
        rr0 = 0.0
        rr1 = 0.0
    else:
        rr0 = (rel0 - s[S.rel]) / Ts
        rr1 = (rel1 - s[S.rel + 1]) / Ts
    s[S.rel] = rel0
    s[S.rel + 1] = rel1
    lg[0] = rel0
    lg[1] = rel1
    psi = s[S.origin] + (rel0 + rel1) / 2.0 + th_hat - s[S.theta0]
    alpha = s[S.origin + 1] + (rel0 - rel1) / (2.0 * bor)
    psi_dot = (rr0 + rr1) / 2.0 + thd_hat
    alpha_dot = (rr0 - rr1) / (2.0 * bor)
    if k > 0:
        v = p[P.r] * psi_dot
        s[S.pos] = s[S.pos] + Ts * (v * math.cos(alpha))
        s[S.pos + 1] = s[S.pos + 1] + Ts * (v * math.sin(alpha))
    if p[P.on] != 0.0:
        ym = B.ym
        bus[ym], bus[ym + 2], bus[ym + 3], bus[ym + 5] = psi, alpha, psi_dot, alpha_dot
        bus[ym + 6], bus[ym + 7] = s[S.pos], s[S.pos + 1]


ELEMENT = Element(
    name="encoder", code=CODE, stage="sensor", place=30, params=PARAMS, state=STATE, pack=_pack,
    logs=(("encoder_angles", 2),), switches=("encoder",),
    doc="quadrature encoders on the motor shafts, odometry",
)  # fmt: skip
