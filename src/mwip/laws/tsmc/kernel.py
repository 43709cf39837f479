"""Compiled sample-time evaluation of the terminal SMC (4.30)-(4.32), (4.43) for a batch.

The one implementation of the law (:class:`mwip.laws.tsmc.controller.TSMC` calls it): subsystem
(4.26)-(4.27), augmenting cubics (4.43), surface (4.30), gain and law (4.32) in one loop;
``F, G`` from the closed forms of (2.36) (:func:`mwip.models.reduced.f_g_terms`). Its oracle,
the NumPy forms written from the equations, is in tests/oracle_laws.py; tests/test_kernels.py
holds the two equal on random non-zero inputs for every term, and
benchmarks/mutate_kernels.py checks that a sign flip here fails them.
"""

from __future__ import annotations

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.tsmc.packing import (
    CODE,  # noqa: F401 - the dispatcher reads kernel.CODE
    P_C,
    P_COEF,
    P_CUBIC,
    P_D,
    P_GAMMA,
    P_IDINV,
    P_PHI,
    P_RATIO,
    P_REFS,
    P_SAT,
    P_T0,
    P_TF,
    X_AUG,
    X_K,
    X_S,
)  # fmt: skip
from mwip.models._compiled import f_g_scalar


@njit
def tsmc_step(c, q, qd, t, tau, coeffs, Tf, C, ratio, D, IDinv, Gam, sat, phi,  # noqa: ANN001, ANN201
              refs, u, s_out, k_out, a_out):  # fmt: skip
    """Fill ``u`` = ``[u_r, u_l]``, ``s``, ``k`` and the augmenting values ``a`` (all (N, 2)).

    ``c`` (10,) nominal coefficients; ``q, qd`` (N, 3); ``t`` time, ``tau = t - t0`` time since
    the cubics were fitted; ``coeffs`` (M, 2, 4) of (4.43) for the M plants (row ``i`` uses
    plant ``i mod M``: the continuous mode stacks perturbed copies); ``C, Gam`` (2,); ``D, IDinv``
    (2, 2) with ``IDinv = (I - D)^-1``; ``refs = [theta*, alpha*(0), alpha'*]``.
    """
    for i in range(q.shape[0]):
        f1, f2, f3, g1, g2, g3 = f_g_scalar(
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
            q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2],
        )  # fmt: skip
        F = (f2, f3)  # subsystem (4.26)-(4.27): rows theta', alpha' of (2.31)
        e = (q[i, 1] - refs[0], q[i, 2] - refs[1] - refs[2] * t)
        ed = (qd[i, 1], qd[i, 2] - refs[2])
        w = [0.0, 0.0]
        nt = [0.0, 0.0]
        sw = [0.0, 0.0]
        for j in range(2):
            if tau > Tf:
                a = ad = add = 0.0
            else:
                cf = coeffs[i % coeffs.shape[0], j]  # rows beyond the batch repeat it
                a0, a1, a2, a3 = cf[0], cf[1], cf[2], cf[3]
                a = a0 + a1 * tau + a2 * tau**2 + a3 * tau**3
                ad = a1 + 2.0 * a2 * tau + 3.0 * a3 * tau**2
                add = 2.0 * a2 + 6.0 * a3 * tau
            s = ed[j] + C[j] * e[j] - ad - C[j] * a
            s_out[i, j] = s
            a_out[i, j] = a
            if sat:
                sw[j] = min(1.0, max(-1.0, s / phi))
            else:
                sw[j] = (s > 0.0) - (s < 0.0)
            nt[j] = F[j] + C[j] * ed[j] - add - C[j] * ad
            w[j] = -F[j] - C[j] * ed[j] + add + C[j] * ad
        # k = (I - D)^-1 (F~ + D |nominal term| + Gamma)
        rhs0 = ratio * abs(F[0]) + D[0, 0] * abs(nt[0]) + D[0, 1] * abs(nt[1]) + Gam[0]
        rhs1 = ratio * abs(F[1]) + D[1, 0] * abs(nt[0]) + D[1, 1] * abs(nt[1]) + Gam[1]
        for j in range(2):
            k_out[i, j] = IDinv[j, 0] * rhs0 + IDinv[j, 1] * rhs1
        w0 = w[0] - k_out[i, 0] * sw[0]
        w1 = w[1] - k_out[i, 1] * sw[1]
        # G1 = [[g2, g2], [g3, -g3]]: u = G1^-1 w
        u[i, 0] = 0.5 * w0 / g2 + 0.5 * w1 / g3
        u[i, 1] = 0.5 * w0 / g2 - 0.5 * w1 / g3


@njit(inline="always")
def step(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201, ARG001 - compiled kernel
    """One sample of the packed law (:mod:`.packing`) for one robot: :func:`tsmc_step` at the
    measurement ``ym`` (1, 8) with this robot's cubics. Logs ``[s, k, aug]``."""
    s = x[X_S : X_S + 2].reshape((1, 2))
    kk = x[X_K : X_K + 2].reshape((1, 2))
    a = x[X_AUG : X_AUG + 2].reshape((1, 2))
    tsmc_step(p[P_COEF[0] : P_COEF[1]], ym[:, 0:3], ym[:, 3:6], t, t - p[P_T0],
              p[P_CUBIC[0] : P_CUBIC[1]].reshape((1, 2, 4)), p[P_TF], p[P_C[0] : P_C[1]],
              p[P_RATIO], p[P_D[0] : P_D[1]].reshape((2, 2)),
              p[P_IDINV[0] : P_IDINV[1]].reshape((2, 2)), p[P_GAMMA[0] : P_GAMMA[1]],
              p[P_SAT] != 0.0, p[P_PHI], p[P_REFS[0] : P_REFS[1]], u, s, kk, a)  # fmt: skip
    for j in range(2):
        lg[j] = s[0, j]
        lg[2 + j] = kk[0, j]
        lg[4 + j] = a[0, j]
