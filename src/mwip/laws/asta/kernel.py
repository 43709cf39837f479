"""Compiled sample-time terms of the adaptive super-twisting family: the sliding variables
(4.1) and ``sigma' = a + b [u_A, u_B]`` (4.10)-(4.11) on the nominal model, for a batch.

The one implementation of (4.1) and (4.10)-(4.11) (:class:`mwip.laws.asta.controller.ASTA`,
:class:`~mwip.laws.asta.controller.ASMC` and :func:`~mwip.laws.asta.controller.asta_surface`
call it), with
``F, G`` from the closed forms of (2.36) (:func:`mwip.models.reduced.f_g_terms`). Its oracle
is in tests/oracle_laws.py; tests/test_kernels.py holds the two equal on random non-zero
inputs, and benchmarks/mutate_kernels.py checks that a sign flip here fails them.
"""

from __future__ import annotations

import math

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.asta.packing import (
    CODE,  # noqa: F401 - the dispatcher reads kernel.CODE
    P_ASMC,
    P_COEF,
    P_EPS,
    P_K,
    P_LAM,
    P_RATE,
    P_REF,
    P_TS,
    X_A,
    X_B,
    X_GAMMA,
    X_S,
    X_W,
)  # fmt: skip
from mwip.models._compiled import f_g_scalar


@njit
def asta_terms(c, q, qd, lam, ref, s, a, b):  # noqa: ANN001, ANN201 - compiled kernel
    """Fill ``s``, ``a``, ``b`` (N, 2); ``c`` (10,) coefficients, ``q, qd`` (N, 3),
    ``lam = (l1, l2, l3)``, ``ref = (psi'_d, theta_d, alpha_d, alpha'_d)``."""
    l1, l2, l3 = lam[0], lam[1], lam[2]
    for i in range(q.shape[0]):
        f1, f2, f3, g1, g2, g3 = f_g_scalar(
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
            q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2],
        )  # fmt: skip
        s[i, 0] = qd[i, 1] + l1 * (q[i, 1] - ref[1]) + l2 * (qd[i, 0] - ref[0])
        s[i, 1] = (qd[i, 2] - ref[3]) + l3 * (q[i, 2] - ref[2])
        a[i, 0] = f2 + l2 * f1 + l1 * qd[i, 1]
        a[i, 1] = f3 + l3 * qd[i, 2]
        b[i, 0] = g2 + l2 * g1
        b[i, 1] = g3


@njit
def asta_sample(a, b, s, K, rate, eps, Ts, asmc, Gamma, w, u):  # noqa: ANN001, ANN201
    """The law and the state update of one sample, for a batch (the one implementation of
    :class:`mwip.laws.asta.controller.ASTA` and :class:`~mwip.laws.asta.controller.ASMC`'s
    ``__call__``).

    Fills ``u`` (N, 2) = ``[u_r, u_l]`` from ``a, b, s`` (N, 2) of :func:`asta_terms`:
    ASTA (4.7) ``u_i = (-a_i - K_i |s_i|^(1/2) sgn s_i + w_i) / b_i``; ASMC (``asmc``) the same
    with ``-Gamma_i sgn s_i`` for ``w_i``. Then, in place, ASTA's integrator (4.4)
    ``w <- w - Ts Gamma sgn s`` (with the current gain) and the adaptive law (4.5)
    ``Gamma <- Gamma + Ts rate |s|`` where ``|s| >= eps`` (forward Euler over ``Ts``).
    """
    for i in range(s.shape[0]):
        uab0 = 0.0
        uab1 = 0.0
        for j in range(2):
            sj = s[i, j]
            sg = (sj > 0.0) - (sj < 0.0)
            sta = -K[j] * math.sqrt(abs(sj)) * sg  # (4.3)'s proportional term
            if asmc:
                v = (-a[i, j] + sta + (-Gamma[i, j] * sg)) / b[i, j]
            else:
                v = (-a[i, j] + sta + w[i, j]) / b[i, j]
            if j == 0:
                uab0 = v
            else:
                uab1 = v
        u[i, 0] = 0.5 * (uab0 + uab1)
        u[i, 1] = 0.5 * (uab0 - uab1)
        for j in range(2):
            sj = s[i, j]
            sg = (sj > 0.0) - (sj < 0.0)
            if not asmc:
                w[i, j] = w[i, j] - Ts * Gamma[i, j] * sg
            grow = rate[j] * abs(sj) if abs(sj) >= eps else 0.0
            Gamma[i, j] = Gamma[i, j] + Ts * grow


@njit(inline="always")
def step(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201, ARG001 - compiled kernel
    """One sample of the packed law (:mod:`.packing`) for one robot: :func:`asta_terms` at
    the measurement ``ym`` (1, 8), then :func:`asta_sample` (the law and the update of the
    gains in ``x``). Logs ``[sigma, Gamma, w]`` with the gains before the update, as the
    Python class does."""
    s = x[X_S : X_S + 2].reshape((1, 2))
    a = x[X_A : X_A + 2].reshape((1, 2))
    b = x[X_B : X_B + 2].reshape((1, 2))
    G = x[X_GAMMA : X_GAMMA + 2].reshape((1, 2))
    w = x[X_W : X_W + 2].reshape((1, 2))
    asta_terms(p[P_COEF[0] : P_COEF[1]], ym[:, 0:3], ym[:, 3:6], p[P_LAM[0] : P_LAM[1]],
               p[P_REF[0] : P_REF[1]], s, a, b)  # fmt: skip
    for j in range(2):
        lg[j] = s[0, j]
        lg[2 + j] = G[0, j]
        lg[4 + j] = w[0, j]
    asta_sample(a, b, s, p[P_K[0] : P_K[1]], p[P_RATE[0] : P_RATE[1]], p[P_EPS], p[P_TS],
                p[P_ASMC] != 0.0, G, w, u)  # fmt: skip
