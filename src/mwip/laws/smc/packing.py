"""The sliding-mode family's packing: SMC (3.49)-(3.50), with or without the high-order
disturbance observer (3.20)-(3.23) (DO-based SMC / HODOSMC), :mod:`.kernel`.

Parameters, for an observer of state dimension ``m = 3 n`` (``m = 0``: plain SMC)::

    m | coef (10) | lam (4) | K1 K2 sat phi q1d_dot q3d | obs_Ts hold decoupled |
    Phi (m, m) | Gamma (m, 3)

``coef`` the nominal model's coefficients (:data:`mwip.models.reduced.COEFF_NAMES`), ``lam``
the surface (3.49), ``K1, K2`` the switching gains, ``sat`` 1 for ``clip(s / phi)`` (0:
``sgn``), ``q1d_dot, q3d`` the references; ``hold`` the observer's model-term code
(:data:`mwip.core.HOLD_CODES`), ``decoupled`` 1 when no entry of ``Phi, Gamma`` couples two
channels (:func:`mwip.observers._hodo_kernel.channels_decoupled`). The fixed part comes first,
so the kernel finds ``Phi`` at :data:`FIXED` and ``Gamma`` at ``FIXED + m m``.

State: the disturbance estimate ``th`` (3) the law uses, the previous measurement's rates
``qd_prev`` (3) and model terms ``fg_prev`` (6) (the observer's ``"start"``/``"trapezoid"``
holds), the torque ``u_prev`` (2) held over the last sample, the observer state ``z`` (m) and
scratch ``work`` (m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mwip.laws.packing import Field, Layout, PackedLaw

__all__ = ["CODE", "params_layout", "state_layout", "LOGS", "pack", "FIXED"]

CODE = 1
LOGS = (("S1", 1), ("S2", 1), ("tau_hat", 3))

_FIXED_FIELDS = (
    Field("m", (), "observer state dimension 3n (0: no observer)"),
    Field("coef", (10,), "nominal model coefficients (2.33)"),
    Field("lam", (4,), "surface (3.49): lambda_1..lambda_4"),
    Field("K1", (), "switching gain of s1 (N m)"),
    Field("K2", (), "switching gain of s2 (N m)"),
    Field("sat", (), "1: saturation clip(s/phi), 0: sgn"),
    Field("phi", (), "boundary layer width"),
    Field("q1d_dot", (), "wheel speed reference (rad/s)"),
    Field("q3d", (), "yaw reference (rad)"),
    Field("obs_Ts", (), "observer sample period (s)"),
    Field("hold", (), "observer model-term hold code"),
    Field("decoupled", (), "1: Phi, Gamma couple no channels"),
)  # fmt: skip
_FIX = Layout(_FIXED_FIELDS)
#: Length of the fixed part: ``Phi`` starts here.
FIXED = _FIX.size
P_COEF = _FIX.span("coef")
P_LAM = _FIX.span("lam")
P_K1, P_K2, P_SAT, P_PHI, P_Q1D_DOT, P_Q3D, P_OBS_TS, P_HOLD, P_DECOUPLED = (
    _FIX.span(n)[0] for n in ("K1", "K2", "sat", "phi", "q1d_dot", "q3d", "obs_Ts", "hold",
                             "decoupled")
)  # fmt: skip
#: State offsets (the observer's ``z`` and ``work`` follow at ``Z``, ``Z + m``).
X_TH, X_QD_PREV, X_FG_PREV, X_U_PREV, X_Z = 0, 3, 6, 12, 14


def params_layout(m: int) -> Layout:
    """The parameter layout for an observer of state dimension ``m`` (0: none)."""
    return Layout(_FIXED_FIELDS + (Field("Phi", (m, m), "observer transition (3.23)"),
                                   Field("Gamma", (m, 3), "observer input matrix")))  # fmt: skip


def state_layout(m: int) -> Layout:
    return Layout((
        Field("th", (3,), "disturbance estimate used by the law"),
        Field("qd_prev", (3,), "previous measured rates"),
        Field("fg_prev", (6,), "previous model terms F, G of (2.36)"),
        Field("u_prev", (2,), "torque held over the last sample"),
        Field("z", (m,), "observer state"),
        Field("work", (m,), "scratch"),
    ))  # fmt: skip


def _decoupled(Phi: np.ndarray, Gam: np.ndarray) -> bool:
    m = Phi.shape[0]
    ch = np.arange(m) % 3
    return bool(np.all(Phi[ch[:, None] != ch[None, :]] == 0.0)
                and np.all(Gam[ch[:, None] != np.arange(3)[None, :]] == 0.0))  # fmt: skip


def pack(coef: ArrayLike, lam: ArrayLike, K1: float, K2: float, sat: bool, phi: float,
         q1d_dot: float, q3d: float, Phi: ArrayLike | None = None,
         Gamma: ArrayLike | None = None, obs_Ts: float = 1.0, hold: int = 0,
         name: str = "smc") -> PackedLaw:  # fmt: skip
    """The packed law of one setting (``Phi = None``: no observer)."""
    P = np.zeros((0, 0)) if Phi is None else np.asarray(Phi, dtype=float)
    G = np.zeros((0, 3)) if Gamma is None else np.asarray(Gamma, dtype=float)
    m = P.shape[0]
    lay = params_layout(m)
    p = lay.pack({
        "m": m, "coef": coef, "lam": lam, "K1": K1, "K2": K2, "sat": float(sat), "phi": phi,
        "q1d_dot": q1d_dot, "q3d": q3d, "obs_Ts": obs_Ts if m else 1.0,
        "hold": hold if m else 0, "decoupled": float(_decoupled(P, G)), "Phi": P, "Gamma": G,
    })  # fmt: skip
    st = state_layout(m)
    return PackedLaw(CODE, p[None, :], np.zeros((1, st.size)), lay, st, LOGS, name)
