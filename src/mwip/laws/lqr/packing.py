"""The LQR law's packing: ``u = y[:6] @ gain + offset`` (Sec. 4.4.2, :mod:`.kernel`).

Parameters: ``gain`` (6, 2), the feedback ``-K`` with the selection of
``x = [theta, alpha, theta', v, alpha']`` from the measured ``y[:6]`` folded in, and ``offset``
(2,), the reference term ``K x_ref``. No state: the law is static.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mwip.laws.packing import Field, Layout, PackedLaw

__all__ = ["CODE", "PARAMS", "STATE", "LOGS", "pack"]

#: The law code of :mod:`mwip.laws.dispatch`.
CODE = 0
PARAMS = Layout((
    Field("gain", (6, 2), "u = y[:6] @ gain + offset: -K with the state selection folded in"),
    Field("offset", (2,), "K x_ref (N m)"),
))  # fmt: skip
STATE = Layout(())
LOGS: tuple[tuple[str, int], ...] = ()

#: Offsets the compiled kernel reads (tests/test_packing.py holds them to :data:`PARAMS`).
GAIN = PARAMS.span("gain")
OFFSET = PARAMS.span("offset")


def pack(gain: ArrayLike, offset: ArrayLike) -> PackedLaw:
    """The packed LQR law of one gain set."""
    p = PARAMS.pack({"gain": gain, "offset": offset})
    return PackedLaw(CODE, p[None, :], np.zeros((1, 0)), PARAMS, STATE, LOGS, "lqr")
