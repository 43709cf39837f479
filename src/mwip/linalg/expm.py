"""Matrix exponential by scaling and squaring with Pade approximants.

Algorithm 5.1 of A. H. Al-Mohy and N. J. Higham, "A new scaling and squaring algorithm for
the matrix exponential", SIAM J. Matrix Anal. Appl. 31(3):970-989, 2009 (the refinement of
N. J. Higham, "The scaling and squaring method for the matrix exponential revisited", SIAM
J. Matrix Anal. Appl. 26(4):1179-1193, 2005; the algorithm behind ``scipy.linalg.expm``):

.. math::

    e^A = \\big(r_m(2^{-s} A)\\big)^{2^s}, \\qquad
    r_m(X) = q_m(X)^{-1} p_m(X), \\quad q_m(X) = p_m(-X),

with the diagonal ``[m/m]`` Pade approximant, ``m`` in {3, 5, 7, 9, 13}. The degree and the
scaling ``s`` are the cheapest for which the backward error is below the unit round-off
``u = 2^-53``: ``m`` is chosen by comparing ``eta = max(d_{2p}, d_{2p+2})`` with the
thresholds ``theta_m`` (Higham 2005, Table 2.3), ``d_k = ||A^k||_1^{1/k}`` (2009, Thm 4.2;
this bound, smaller than ``||A||_1`` for non-normal ``A``, avoids over-scaling), and
``ell(A, m)`` (2009, (5.1)) adds squarings where the rounding of the Pade evaluation calls
for them. The norms are computed exactly (the matrices here are small), where the paper
estimates them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.linalg._check import square

__all__ = ["expm"]

#: Pade coefficients b_0 .. b_m of p_m (Higham 2005, (2.11) and Algorithm 2.3).
_B: dict[int, tuple[float, ...]] = {
    3: (120.0, 60.0, 12.0, 1.0),
    5: (30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0),
    7: (17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0),
    9: (17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0, 2162160.0,
        110880.0, 3960.0, 90.0, 1.0),
    13: (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
         129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
         40840800.0, 960960.0, 16380.0, 182.0, 1.0),
}  # fmt: skip

#: theta_m: largest ||2^-s A|| for which r_m has backward error <= u (Higham 2005, Table 2.3).
_THETA = {3: 1.495585217958292e-2, 5: 2.539398330063230e-1, 7: 9.504178996162932e-1,
          9: 2.097847961257068e0, 13: 5.371920351148152e0}  # fmt: skip

_LOG2_U = -53.0  # unit round-off of IEEE double, u = 2^-53


def _norm1(a: NDArray) -> float:
    return float(np.abs(a).sum(axis=0).max())


def _ell(a: NDArray, m: int) -> int:
    """Extra squarings ``ell(A, m)`` of Al-Mohy & Higham 2009, (5.1).

    ``alpha = |c_{2m+1}| || |A|^{2m+1} ||_1 / ||A||_1`` with ``|c_{2m+1}| = (m!)^2 /
    ((2m)! (2m+1)!)``, the leading coefficient of ``e^x - r_m(x)``;
    ``ell = max(ceil(log2(alpha / u) / (2m)), 0)``. The power's norm is computed exactly (in
    log2, to avoid overflow) as the largest entry of ``1^T |A|^{2m+1}``.
    """
    norm_a = _norm1(a)
    if norm_a == 0.0:
        return 0
    abs_a = np.abs(a)
    v = np.ones(a.shape[0])
    log2_pow = 0.0
    for _ in range(2 * m + 1):
        v = v @ abs_a
        top = float(v.max())
        if top == 0.0:  # |A| nilpotent: the Pade error series vanishes
            return 0
        v /= top
        log2_pow += math.log2(top)
    log2_c = 2 * math.lgamma(m + 1) - math.lgamma(2 * m + 1) - math.lgamma(2 * m + 2)
    log2_alpha = log2_c / math.log(2.0) + log2_pow - math.log2(norm_a)
    return max(math.ceil((log2_alpha - _LOG2_U) / (2 * m)), 0)


def _pade(a: NDArray, m: int, powers: dict[int, NDArray]) -> NDArray:
    """``r_m(A) = (V - U)^{-1} (V + U)`` with ``p_m(A) = V + U`` split in even ``V`` and odd ``U``
    parts (Higham 2005, Algorithm 2.3; the degree-13 form with 6 products, (2.12))."""
    b = _B[m]
    ident = np.eye(a.shape[0], dtype=a.dtype)
    a2 = powers[2]
    if m == 13:
        a4, a6 = powers[4], powers[6]
        u = a @ (a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2)
                 + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * ident)  # fmt: skip
        v = (a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2)
             + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * ident)  # fmt: skip
    else:
        u_sum = b[1] * ident
        v = b[0] * ident
        for j in range(2, m + 1, 2):
            u_sum = u_sum + b[j + 1] * powers[j]
            v = v + b[j] * powers[j]
        u = a @ u_sum
    return np.linalg.solve(v - u, v + u)


def expm(A: ArrayLike) -> NDArray:
    """The matrix exponential ``e^A`` of a square real or complex array (like SciPy's).

    Al-Mohy & Higham 2009, Algorithm 5.1 (module docstring). Raises ``ValueError`` for an
    array that is not square 2-D or not finite.

    >>> expm([[0.0, 1.0], [0.0, 0.0]]).tolist()
    [[1.0, 1.0], [0.0, 1.0]]
    """
    a = square("A", A)
    n = a.shape[0]
    if n == 0:
        return a.copy()
    if n == 1:
        return np.exp(a)
    powers = {2: a @ a}
    powers[4] = powers[2] @ powers[2]
    powers[6] = powers[2] @ powers[4]
    d4 = _norm1(powers[4]) ** 0.25
    d6 = _norm1(powers[6]) ** (1.0 / 6.0)
    eta1 = max(d4, d6)
    for m in (3, 5):
        if eta1 <= _THETA[m] and _ell(a, m) == 0:
            return _pade(a, m, powers)
    powers[8] = powers[4] @ powers[4]
    d8 = _norm1(powers[8]) ** 0.125
    eta3 = max(d6, d8)
    for m in (7, 9):
        if eta3 <= _THETA[m] and _ell(a, m) == 0:
            return _pade(a, m, powers)
    d10 = _norm1(powers[4] @ powers[6]) ** 0.1
    eta5 = min(eta3, max(d8, d10))
    s = max(math.ceil(math.log2(eta5 / _THETA[13])), 0) if eta5 > 0 else 0
    s += _ell(a * 2.0**-s, 13)
    scale = 2.0**-s
    a_s = a * scale
    scaled = {2: powers[2] * scale**2, 4: powers[4] * scale**4, 6: powers[6] * scale**6}
    r = _pade(a_s, 13, scaled)
    for _ in range(s):
        r = r @ r
    return r
