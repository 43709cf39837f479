"""Compiled batch loops over the model's scalar kernels (one source of the equations)."""

from __future__ import annotations

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.models.reduced import f_g_terms

#: The closed forms of (2.36) compiled (inlined into every kernel that needs ``F, G``).
f_g_scalar = njit(inline="always")(f_g_terms)


@njit
def f_g_batch(c, q, qd, F, G):  # noqa: ANN001, ANN201 - compiled kernel
    """Fill ``F`` (N, 3) and the nonzero entries of ``G`` (N, 3, 2) of (2.36) for one robot's
    coefficients ``c`` (10,) at the states ``q, qd`` (N, 3)."""
    for i in range(q.shape[0]):
        f1, f2, f3, g1, g2, g3 = f_g_scalar(
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
            q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2],
        )  # fmt: skip
        F[i, 0] = f1
        F[i, 1] = f2
        F[i, 2] = f3
        G[i, 0, 0] = g1
        G[i, 1, 0] = g2
        G[i, 2, 1] = g3


@njit
def f_plus_g_u(c, q, qd, uAB, out):  # noqa: ANN001, ANN201 - compiled kernel
    """``out = F + G [u_A, u_B]`` (N, 3) of (2.36) for one robot's coefficients ``c`` (10,)
    at ``q, qd`` (N, 3) with ``uAB`` (N, 2): the nominal acceleration a sample-time observer
    subtracts from the measured one."""
    for i in range(q.shape[0]):
        f1, f2, f3, g1, g2, g3 = f_g_scalar(
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
            q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2],
        )  # fmt: skip
        out[i, 0] = f1 + g1 * uAB[i, 0]
        out[i, 1] = f2 + g2 * uAB[i, 0]
        out[i, 2] = f3 + g3 * uAB[i, 1]
    return out
