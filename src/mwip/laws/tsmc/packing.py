"""The terminal sliding-mode law's packing: (4.26)-(4.32) with the fitted cubics of (4.43),
:mod:`.kernel`.

Parameters: ``coef`` (10) nominal model coefficients, ``Tf`` (the cubics' horizon), ``ratio``
(``F~ / |F|``), ``sat`` (1: ``clip(s / phi)``, 0: ``sgn``), ``phi``, ``t0`` (when the cubics
were fitted), ``C`` (2), ``Gamma`` (2), ``D`` (2, 2), ``IDinv = (I - D)^-1`` (2, 2), ``refs``
(3) = ``[theta*, alpha*(0), alpha'*]`` and the robot's cubics ``cubic`` (2, 4) of (4.43): they
are fitted at ``reset`` from each robot's initial state, so a batch carries one parameter
vector per robot. State: scratch ``s, k, aug`` (2 each), the logs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mwip.laws.packing import Field, Layout, PackedLaw, stack

__all__ = ["CODE", "PARAMS", "STATE", "LOGS", "pack"]

CODE = 2
PARAMS = Layout((
    Field("coef", (10,), "nominal model coefficients (2.33)"),
    Field("Tf", (), "horizon of the augmenting cubics (s)"),
    Field("ratio", (), "F~ / |F| bound ratio"),
    Field("sat", (), "1: saturation clip(s/phi), 0: sgn"),
    Field("phi", (), "boundary layer width"),
    Field("t0", (), "time the cubics were fitted (s)"),
    Field("C", (2,), "surface slopes (4.28)"),
    Field("Gamma", (2,), "reaching margins (4.32)"),
    Field("D", (2, 2), "uncertainty bound of the input gain (4.31)"),
    Field("IDinv", (2, 2), "(I - D)^-1"),
    Field("refs", (3,), "theta*, alpha*(0), alpha'*"),
    Field("cubic", (2, 4), "the robot's augmenting cubics (4.43)"),
))  # fmt: skip
STATE = Layout((
    Field("s", (2,), "scratch: sliding variables"),
    Field("k", (2,), "scratch: switching gains"),
    Field("aug", (2,), "scratch: augmenting values"),
))  # fmt: skip
LOGS = (("s", 2), ("k", 2), ("aug", 2))

P_COEF, P_C, P_GAMMA, P_D, P_IDINV, P_REFS, P_CUBIC = (
    PARAMS.span(n) for n in ("coef", "C", "Gamma", "D", "IDinv", "refs", "cubic")
)
P_TF, P_RATIO, P_SAT, P_PHI, P_T0 = (PARAMS.span(n)[0] for n in ("Tf", "ratio", "sat", "phi",
                                                                  "t0"))  # fmt: skip
X_S, X_K, X_AUG = (STATE.span(n)[0] for n in ("s", "k", "aug"))


def pack(coef: ArrayLike, Tf: float, ratio: float, sat: bool, phi: float, t0: float,
         C: ArrayLike, Gamma: ArrayLike, D: ArrayLike, IDinv: ArrayLike, refs: ArrayLike,
         cubic: ArrayLike) -> PackedLaw:  # fmt: skip
    """The packed law; ``cubic`` (N, 2, 4), one robot's cubics per parameter row."""
    cub = np.asarray(cubic, dtype=float).reshape(-1, 2, 4)
    laws = []
    for c in cub:
        p = PARAMS.pack({"coef": coef, "Tf": Tf, "ratio": ratio, "sat": float(sat),
                         "phi": phi, "t0": t0, "C": C, "Gamma": Gamma, "D": D,
                         "IDinv": IDinv, "refs": refs, "cubic": c})  # fmt: skip
        laws.append(PackedLaw(CODE, p[None, :], np.zeros((1, STATE.size)), PARAMS, STATE, LOGS,
                              "tsmc"))  # fmt: skip
    return laws[0] if len(laws) == 1 else stack(laws)
