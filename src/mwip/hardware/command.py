"""Disturbances of the command on its way to the firmware (element ``command``, optional).

Not a part of the book's robot: a robustness axis of ``mwip bench`` (docs/bench.md), run
only when a run asks for it (the packing context's ``extra["command"]``: per robot ``sigma``,
``whole`` and ``rho``). Per sample ``k`` and wheel, before the firmware's own delay:

1. torque noise ``u <- u + sigma e_k`` (``e_k`` two standard normal variates per sample);
2. a delay of ``whole`` whole samples (0 to :data:`MAX_WHOLE`; the firmware's fractional
   delay adds to it): ``u <- u_{k - whole}``, the commands before the start being 0;
3. a first-order responsiveness ``y_k = y_{k-1} + rho (u_k - y_{k-1})``, ``y_{-1} = 0``.

Each step acts only where some robot of the batch asks for it (a noise-free or ``rho = 1``
batch passes the command unchanged, bit for bit).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["ELEMENT", "step", "CODE", "MAX_WHOLE"]

#: The longest whole-sample delay.
MAX_WHOLE = 8

#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 9

PARAMS = Layout((
    Field("sigma", (), "torque noise (N m)"),
    Field("whole", (), "whole samples of delay"),
    Field("rho", (), "responsiveness in (0, 1]"),
    Field("any_noise", (), "1: some robot of the batch has torque noise"),
    Field("depth", (), "the batch's longest whole-sample delay"),
    Field("any_lag", (), "1: some robot of the batch has rho < 1"),
))  # fmt: skip
STATE = Layout((
    Field("fifo", (MAX_WHOLE + 1, 2), "the last commands, newest first (N m)"),
    Field("y", (2,), "the lag's output (N m)"),
))  # fmt: skip
P = PARAMS.index()
S = STATE.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    spec: Mapping[str, Any] = ctx.extra["command"]
    sigma = ctx.rows(spec.get("sigma", 0.0))
    whole = ctx.rows(spec.get("whole", 0))
    rho = ctx.rows(spec.get("rho", 1.0))
    if np.any(~np.isfinite(sigma) | (sigma < 0)):
        raise ValueError("command: 'sigma' must be finite and >= 0")
    if np.any((whole != np.round(whole)) | (whole < 0) | (whole > MAX_WHOLE)):
        raise ValueError(f"command: 'whole' must be an integer in [0, {MAX_WHOLE}]")
    if np.any(~np.isfinite(rho) | (rho <= 0) | (rho > 1)):
        raise ValueError("command: 'rho' must be finite and in (0, 1]")
    return {"sigma": sigma, "whole": whole, "rho": rho,
            "any_noise": float(np.any(sigma > 0.0)), "depth": float(whole.max(initial=0)),
            "any_lag": float(np.any(rho < 1.0))}  # fmt: skip


@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The command's noise, whole-sample delay and lag (module docstring)."""
    depth = int(p[P.depth])
    whole = int(p[P.whole])
    for w in range(2):
        u = bus[B.u + w]
        if p[P.any_noise] != 0.0:
            u = u + p[P.sigma] * z[w]
        if depth > 0:
            for j in range(depth, 0, -1):
                s[S.fifo + 2 * j + w] = s[S.fifo + 2 * (j - 1) + w]
            s[S.fifo + w] = u
            u = s[S.fifo + 2 * whole + w]
        if p[P.any_lag] != 0.0:
            u = s[S.y + w] + p[P.rho] * (u - s[S.y + w])
            s[S.y + w] = u
        bus[B.u + w] = u


ELEMENT = Element(
    name="command", code=CODE, stage="drive", place=10, params=PARAMS, state=STATE,
    pack=_pack, noise=2,
    optional=True, doc="torque noise, whole-sample delay and lag of the command (mwip bench)",
)  # fmt: skip
