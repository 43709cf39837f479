"""The Fig. 5.3 fuzzy law's packing: the PDC balance law (5.10) with the position and
direction Mamdani FLSs of Section 5.3.2, IT2 or type 1 (:mod:`.kernel`).

Parameters, for FLS blocks of width ``L``::

    L | row (14) | fls (4, L)

``row`` = ``[kind (0 IT2, 1 type 1), G (2 x 4 row-major), p_d, alpha_d, position on,
direction on, r_nom]`` (:data:`mwip.fuzzy.layout.ROW_WIDTH`), ``fls`` the four FLS blocks
``[IT2 position, T1 position, IT2 direction, T1 direction]`` (:mod:`mwip.fuzzy.mamdani`'s
block layout; unused kinds zero). A batch whose robots have their own targets or kinds
carries one row per robot. State: scratch ``theta_off, u_alpha``, the logs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mwip.fuzzy.layout import ROW_WIDTH
from mwip.laws.packing import Field, Layout, PackedLaw

__all__ = ["CODE", "params_layout", "STATE", "LOGS", "pack"]

CODE = 4
STATE = Layout((Field("theta_off", (), "scratch: the position FLS's lean (rad)"),
                Field("u_alpha", (), "scratch: the direction FLS's torque (N m)")))  # fmt: skip
LOGS = (("theta_off", 1), ("u_alpha", 1))
#: Offsets: the row at ``P_ROW``, the FLS blocks from ``P_FLS`` (4 L numbers).
P_ROW = 1
P_FLS = 1 + ROW_WIDTH


def params_layout(L: int) -> Layout:
    return Layout((Field("L", (), "FLS block width"),
                   Field("row", (ROW_WIDTH,), "kind, PDC gains, targets, switches, r_nom"),
                   Field("fls", (4, L), "FLS blocks: IT2/T1 position, IT2/T1 direction")))


def pack(rows: ArrayLike, fls: ArrayLike, name: str = "it2") -> PackedLaw:
    """The packed law: ``rows`` (R, 14), one per robot or one for all; ``fls`` (4, L)."""
    R = np.atleast_2d(np.asarray(rows, dtype=float))
    F = np.asarray(fls, dtype=float)
    lay = params_layout(F.shape[1])
    P = np.stack([lay.pack({"L": F.shape[1], "row": r, "fls": F}) for r in R])
    return PackedLaw(CODE, P, np.zeros((1, STATE.size)), lay, STATE, LOGS, name)
