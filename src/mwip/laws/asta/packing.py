"""The adaptive super-twisting family's packing: ASTA (4.1), (4.3)-(4.5), (4.7) and the
adaptive SMC baseline (ASMC), :mod:`.kernel`.

Parameters: ``coef`` (10) nominal model coefficients, ``lam`` (3) of (4.1), ``ref`` (4) =
``[psi'_d, theta_d, alpha_d, alpha'_d]``, ``K`` (2) of (4.3), ``rate`` (2) = ``1/d_i`` of
(4.5), ``Gamma0`` (2), ``eps`` (the adaptation's dead zone), ``Ts`` (the integration period
of (4.4)-(4.5)), ``asmc`` (1: the ASMC law). State: the adaptive gains ``Gamma`` (2) (starting
at ``Gamma0``), ASTA's integral ``w`` (2) (starting at 0), and scratch ``s, a, b`` (2 each).
Logs ``[sigma (2), Gamma (2), w (2)]``, the gains before the sample's update.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mwip.laws.packing import Field, Layout, PackedLaw

__all__ = ["CODE", "PARAMS", "STATE", "LOGS", "pack"]

CODE = 3
PARAMS = Layout((
    Field("coef", (10,), "nominal model coefficients (2.33)"),
    Field("lam", (3,), "surface (4.1)"),
    Field("ref", (4,), "psi'_d, theta_d, alpha_d, alpha'_d"),
    Field("K", (2,), "super-twisting gains (4.3)"),
    Field("rate", (2,), "adaptation rates 1/d_i (4.5)"),
    Field("Gamma0", (2,), "initial adaptive gains"),
    Field("eps", (), "adaptation dead zone |s| >= eps"),
    Field("Ts", (), "integration period of (4.4)-(4.5) (s)"),
    Field("asmc", (), "1: adaptive SMC baseline, 0: ASTA"),
))  # fmt: skip
STATE = Layout((
    Field("Gamma", (2,), "adaptive gains (4.5)"),
    Field("w", (2,), "super-twisting integral (4.4)"),
    Field("s", (2,), "scratch: sliding variables"),
    Field("a", (2,), "scratch: drift term of (4.10)"),
    Field("b", (2,), "scratch: input gain of (4.11)"),
))  # fmt: skip
LOGS = (("sigma", 2), ("Gamma", 2), ("w", 2))

P_COEF, P_LAM, P_REF, P_K, P_RATE = (PARAMS.span(n) for n in ("coef", "lam", "ref", "K", "rate"))
P_EPS, P_TS, P_ASMC = (PARAMS.span(n)[0] for n in ("eps", "Ts", "asmc"))
X_GAMMA, X_W, X_S, X_A, X_B = (STATE.span(n)[0] for n in ("Gamma", "w", "s", "a", "b"))


def pack(coef: ArrayLike, lam: ArrayLike, ref: ArrayLike, K: ArrayLike, rate: ArrayLike,
         Gamma0: ArrayLike, eps: float, Ts: float, asmc: bool) -> PackedLaw:  # fmt: skip
    """The packed law of one setting; the state starts at ``Gamma = Gamma0``, ``w = 0``."""
    p = PARAMS.pack({"coef": coef, "lam": lam, "ref": ref, "K": K, "rate": rate,
                     "Gamma0": Gamma0, "eps": eps, "Ts": Ts, "asmc": float(asmc)})  # fmt: skip
    x = STATE.pack({"Gamma": Gamma0, "w": np.zeros(2), "s": np.zeros(2), "a": np.zeros(2),
                    "b": np.zeros(2)})  # fmt: skip
    return PackedLaw(CODE, p[None, :], x[None, :], PARAMS, STATE, LOGS,
                     "asmc" if asmc else "asta")  # fmt: skip
