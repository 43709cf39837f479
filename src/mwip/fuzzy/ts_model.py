"""Interval type-2 Takagi-Sugeno model of the pitch/wheel dynamics, (5.1)-(5.8).

State and input (Section 5.2): ``x = [theta, theta', psi, psi']`` (pitch, its rate, mean wheel
angle, wheel rate) and the scalar ``u = u_r + u_l = u_A`` (N m). The yaw terms of (5.1) are
treated as disturbances and dropped, as in the book.

Quasi-LPV form (our derivation from (2.32)/(2.36), SPEC.md section 3: the signs are checked
against (2.36), not copied from (5.3)). With ``M0(theta) = [[m11, m12 cos], [m12 cos, m22]]``
acting on ``[psi'', theta'']``::

    M0 [psi'', theta'']^T = [ 2Db theta' - 2(Dw + Db) psi' + u ,
                              Gb k(theta) theta - 2Db theta' + 2Db psi' - u ]^T

where ``sin(theta) = k(theta) theta``. The centripetal term ``m12 sin(theta) theta'^2`` of the
first row is dropped (it is absent from (5.4)/(5.5); it vanishes at rest). This gives
``x' = A(theta) x + B(theta) u``; the vertices are

- ``A1, B1 = A(0), B(0)`` - (5.4) (the linearisation at upright; the book's (5.4) agrees with
  it entry by entry, with ``Delta1 = m11 m22 - m12^2``);
- ``A2, B2 = A(pi/6), B(pi/6)`` - (5.5)/(5.6). Two readings of the gravity factor ``k``:

  * ``reading="sector"`` (default): ``k = sin(theta)/theta`` = 0.955 at pi/6, the sector
    (secant) bound. The TS model is then *exact* at theta = 0 and theta = +-pi/6 (up to the
    dropped centripetal term) - the physically consistent construction;
  * ``reading="book"``: ``k = cos(pi/6)`` = 0.866, as the extraction of (5.5) prints
    (``m11 gb cos(pi/6) x1``), i.e. the slope of ``sin`` at pi/6 without its offset.

  In both, ``cos(theta)`` in the mass matrix and damping coupling is evaluated at pi/6 and
  ``Delta(pi/6) = m11 m22 - m12^2 cos^2(pi/6)`` (the extraction's
  ``beta = m11 m22 - m12 beta1^2`` lost a square on ``m12``).

Membership functions of Fig. 5.1 (triangular IT2 sets, complementary)::

    lower M1 = max(0, 1 - |theta| / (pi/7)),   upper M1 = max(0, 1 - |theta| / (pi/6)),
    lower M2 = 1 - upper M1,                   upper M2 = 1 - lower M1.

(The extraction pairs them as "mu_M2 = 1 - mu_M1"; pairing lower with 1 - upper is the only
reading with lower <= upper.) Beyond |theta| = pi/6 the input is saturated (M2 only).
Nie-Tan (5.8) gives the crisp weights ``m_i = (lower_i + upper_i) / 2``, ``m1 + m2 = 1``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.params import NOMINAL, Params

__all__ = [
    "first_weight",
    "THETA_VERTEX",
    "LOWER_HALF_WIDTH",
    "UPPER_HALF_WIDTH",
    "STATE_NAMES",
    "Reading",
    "TSModel",
    "quasi_lpv",
    "vertex_matrices",
    "memberships",
    "nie_tan_weights",
    "type1_weights",
    "ts_model",
    "nonlinear_rhs",
]

#: The second rule's vertex (5.5): theta = pi/6; the model's domain is [-pi/6, pi/6].
THETA_VERTEX = math.pi / 6
#: Half-widths of the lower / upper membership functions of M1 (Fig. 5.1).
LOWER_HALF_WIDTH = math.pi / 7
UPPER_HALF_WIDTH = math.pi / 6
STATE_NAMES: tuple[str, ...] = ("theta", "theta_dot", "psi", "psi_dot")

Reading = Literal["sector", "book"]


def _gravity_factor(theta: NDArray[np.float64], reading: Reading) -> NDArray[np.float64]:
    if reading == "sector":
        return np.sinc(theta / np.pi)  # sin(theta)/theta, 1 at 0
    if reading == "book":
        return np.cos(theta)
    raise ValueError(f"reading must be 'sector' or 'book', got {reading!r}")


def quasi_lpv(
    p: Params, theta: ArrayLike, reading: Reading = "sector"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``A(theta)`` (..., 4, 4) and ``B(theta)`` (..., 4, 1) of the quasi-LPV form (5.3).

    See the module docstring; ``A(0), B(0)`` is (5.4), ``A(pi/6), B(pi/6)`` is (5.5).
    """
    th = np.asarray(theta, dtype=float)
    c = np.cos(th)
    k = _gravity_factor(th, reading)
    m11, m12, m22 = float(p.m11), float(p.m12), float(p.m22)
    Gb, Db, Dw = float(p.Gb), float(p.Db), float(p.Dw)
    det = m11 * m22 - (m12 * c) ** 2
    shape = th.shape
    # right-hand side R x + e u, rows (psi, theta), columns (theta, theta', psi, psi')
    R = np.zeros((*shape, 2, 4))
    R[..., 0, 1] = 2 * Db
    R[..., 0, 3] = -2 * (Dw + Db)
    R[..., 1, 0] = Gb * k
    R[..., 1, 1] = -2 * Db
    R[..., 1, 3] = 2 * Db
    inv = np.empty((*shape, 2, 2))
    inv[..., 0, 0] = m22 / det
    inv[..., 0, 1] = inv[..., 1, 0] = -m12 * c / det
    inv[..., 1, 1] = m11 / det
    acc = inv @ R  # (..., 2, 4): rows psi'', theta''
    bacc = inv @ np.array([1.0, -1.0])  # (..., 2)
    A = np.zeros((*shape, 4, 4))
    B = np.zeros((*shape, 4, 1))
    A[..., 0, 1] = 1.0
    A[..., 2, 3] = 1.0
    A[..., 1, :] = acc[..., 1, :]
    A[..., 3, :] = acc[..., 0, :]
    B[..., 1, 0] = bacc[..., 1]
    B[..., 3, 0] = bacc[..., 0]
    return A, B


@dataclass(frozen=True)
class TSModel:
    """The two-rule IT2 TS model (5.6): vertices ``A[i], B[i]`` (i = 0 upright, 1 at pi/6)."""

    A: NDArray[np.float64] = field(repr=False)
    B: NDArray[np.float64] = field(repr=False)
    reading: Reading = "sector"
    params: Params = field(default=NOMINAL, repr=False)

    def __post_init__(self) -> None:
        if self.A.shape != (2, 4, 4) or self.B.shape != (2, 4, 1):
            raise ValueError(f"need A (2,4,4), B (2,4,1); got {self.A.shape}, {self.B.shape}")
        if not (np.all(np.isfinite(self.A)) and np.all(np.isfinite(self.B))):
            raise ValueError("vertex matrices must be finite")

    def rhs(self, x: ArrayLike, u: ArrayLike, weights: str = "it2") -> NDArray[np.float64]:
        """Blended model (5.8): ``x' = sum_i m_i(theta) (A_i x + B_i u)``, x (..., 4), u (...)."""
        xx = np.asarray(x, dtype=float)
        uu = np.asarray(u, dtype=float)
        m = nie_tan_weights(xx[..., 0]) if weights == "it2" else type1_weights(xx[..., 0])
        loc = np.einsum("ijk,...k->...ij", self.A, xx) + self.B[..., 0] * uu[..., None, None]
        return np.einsum("...i,...ij->...j", m, loc)


def vertex_matrices(p: Params = NOMINAL, reading: Reading = "sector") -> TSModel:
    """Vertex matrices ``A1, B1`` (5.4) and ``A2, B2`` (5.5)-(5.6) from parameters ``p``."""
    A, B = quasi_lpv(p, np.array([0.0, THETA_VERTEX]), reading)
    return TSModel(A=A, B=B, reading=reading, params=p)


def memberships(
    theta: ArrayLike,
    lower_half_width: float = LOWER_HALF_WIDTH,
    upper_half_width: float = UPPER_HALF_WIDTH,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper memberships of M1, M2 (Fig. 5.1, (5.7)); each (..., 2)."""
    th = np.clip(np.asarray(theta, dtype=float), -THETA_VERTEX, THETA_VERTEX)
    lo1 = np.maximum(0.0, 1.0 - np.abs(th) / lower_half_width)
    up1 = np.maximum(0.0, 1.0 - np.abs(th) / upper_half_width)
    return np.stack([lo1, 1.0 - up1], -1), np.stack([up1, 1.0 - lo1], -1)


def first_weight(theta: ArrayLike, *, type1: bool = False) -> NDArray[np.float64]:
    """Weight ``m_1(theta)`` of the first rule; ``m_2 = 1 - m_1`` (shape of ``theta``).

    Nie-Tan (5.8) with the memberships of Fig. 5.1: since ``M2 = 1 - M1`` on both bounds,
    ``sum_i (lower_i + upper_i) = 2`` and ``m_1 = (lower_1 + upper_1) / 2``. ``type1``: the
    triangle at the middle of the footprint, half-width ``(pi/7 + pi/6) / 2``.
    """
    a = np.abs(np.clip(np.asarray(theta, dtype=float), -THETA_VERTEX, THETA_VERTEX))
    if type1:
        return np.maximum(0.0, 1.0 - a / (0.5 * (LOWER_HALF_WIDTH + UPPER_HALF_WIDTH)))
    lo = np.maximum(0.0, 1.0 - a / LOWER_HALF_WIDTH)
    up = np.maximum(0.0, 1.0 - a / UPPER_HALF_WIDTH)
    return 0.5 * (lo + up)


def nie_tan_weights(theta: ArrayLike) -> NDArray[np.float64]:
    """Normalised Nie-Tan weights ``m_i(theta)`` of (5.8)/(5.10), (..., 2), summing to 1:
    ``m_i = (lower_i + upper_i) / sum_j (lower_j + upper_j)`` with the memberships of
    :func:`memberships`, computed by the compiled PDC kernel
    (:func:`mwip.fuzzy._kernel.pdc_weights`, the one implementation)."""
    return _weights(theta, t1=False)


def type1_weights(theta: ArrayLike) -> NDArray[np.float64]:
    """Type-1 counterpart: M1 is the triangle at the middle of the footprint.

    Half-width ``(pi/7 + pi/6) / 2``; M2 = 1 - M1 (the compiled PDC kernel).
    """
    return _weights(theta, t1=True)


def _weights(theta: ArrayLike, *, t1: bool) -> NDArray[np.float64]:
    from mwip.fuzzy._kernel import pdc_weights_batch  # the kernel imports this module

    th = np.asarray(theta, dtype=float)
    out = np.empty((*th.shape, 2))
    pdc_weights_batch(np.ascontiguousarray(th).reshape(-1), t1, out.reshape(-1, 2))
    return out


def ts_model(p: Params = NOMINAL, reading: Reading = "sector") -> TSModel:
    """Alias of :func:`vertex_matrices`: the IT2 TS model (5.6)-(5.8)."""
    return vertex_matrices(p, reading)


def nonlinear_rhs(p: Params, x: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
    """Pitch/wheel dynamics (5.3) from the reduced model (2.33) with zero yaw, (..., 4).

    Keeps the centripetal term; used to measure how well the TS model approximates the plant.
    """
    from mwip.models.reduced import accelerations

    xx = np.asarray(x, dtype=float)
    uu = np.asarray(u, dtype=float)
    zeros = np.zeros_like(xx[..., 0])
    q = np.stack([xx[..., 2], xx[..., 0], zeros], -1)
    qd = np.stack([xx[..., 3], xx[..., 1], zeros], -1)
    uw = np.stack([uu / 2, uu / 2], -1)
    acc = accelerations(p, q, qd, uw)
    return np.stack([xx[..., 1], acc[..., 1], xx[..., 3], acc[..., 0]], -1)
