"""Compiled sample-time evaluation of the sliding-mode law (3.49)-(3.50) for a batch.

The one implementation of the law (:class:`mwip.laws.smc.controller.SlidingModeController`
calls it),
with ``F, G`` from the closed forms of (2.36) (:func:`mwip.models.reduced.f_g_terms`, the one
source of the model), in one loop so that a controller call costs microseconds rather than a
chain of small NumPy calls. Its oracle, the NumPy form written from (3.49)-(3.50), is in
tests/oracle_laws.py; tests/test_kernels.py holds the two equal on random non-zero inputs
for every term, and benchmarks/mutate_kernels.py checks that a sign flip here fails them.
"""

from __future__ import annotations

import numpy as np

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.smc.packing import (
    CODE,  # noqa: F401 - the dispatcher reads kernel.CODE
    FIXED,
    P_COEF,
    P_DECOUPLED,
    P_HOLD,
    P_K1,
    P_K2,
    P_LAM,
    P_OBS_TS,
    P_PHI,
    P_Q1D_DOT,
    P_Q3D,
    P_SAT,
    X_FG_PREV,
    X_QD_PREV,
    X_TH,
    X_U_PREV,
    X_Z,
)  # fmt: skip
from mwip.models._compiled import f_g_scalar
from mwip.observers._hodo_kernel import hodo_sample, model_terms


@njit(inline="always")
def smc_law(fg, q0, q1, q2, qd0, qd1, qd2, th0, th1, th2, t, lam, K1, K2, sat, phi, q1d_dot,  # noqa: ANN001, ANN201, PLR0913
            q3d):  # fmt: skip
    """(3.49)-(3.50) for one robot: ``(u_r, u_l, s1, s2)``.

    ``fg = (f1, f2, f3, g1, g2, g3)``, the terms of (2.36) at the measurement ``q, q'``
    (:func:`mwip.models._compiled.f_g_scalar`; the compiled loop hands over the ones it has
    evaluated for the observer at the same measurement); ``th`` the disturbance estimate.
    """
    f1, f2, f3, g1, g2, g3 = fg
    l1, l2, l3, l4 = lam[0], lam[1], lam[2], lam[3]
    s1 = qd1 + l1 * q1 + l2 * (q0 - q1d_dot * t) + l3 * (qd0 - q1d_dot)
    s2 = qd2 + l4 * (q2 - q3d)
    if sat:
        w1 = min(1.0, max(-1.0, s1 / phi))
        w2 = min(1.0, max(-1.0, s2 / phi))
    else:
        w1 = (s1 > 0.0) - (s1 < 0.0)
        w2 = (s2 > 0.0) - (s2 < 0.0)
    uA = (
        -f2 - l3 * f1 - l1 * qd1 - l2 * (qd0 - q1d_dot) - th1 - l3 * th0 - K1 * w1
    ) / (g2 + l3 * g1)  # fmt: skip
    uB = (-f3 - l4 * qd2 - th2 - K2 * w2) / g3
    return 0.5 * (uA + uB), 0.5 * (uA - uB), s1, s2


@njit
def smc_step(c, q, qd, tau_hat, t, lam, K1, K2, sat, phi, q1d_dot, q3d, u, S):  # noqa: ANN001, ANN201
    """Fill ``S`` (N, 2) with (3.49) and ``u`` (N, 2) with ``[u_r, u_l]`` from (3.50).

    ``c`` (10,) nominal coefficients; ``q, qd, tau_hat`` (N, 3); ``lam`` (4,);
    ``sat``: saturation ``clip(s / phi, -1, 1)`` instead of ``sgn`` (``sgn(0) = 0``).
    Per robot :func:`smc_law`.
    """
    for i in range(q.shape[0]):
        fg = f_g_scalar(
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
            q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2],
        )  # fmt: skip
        u[i, 0], u[i, 1], S[i, 0], S[i, 1] = smc_law(
            fg, q[i, 0], q[i, 1], q[i, 2], qd[i, 0], qd[i, 1], qd[i, 2],
            tau_hat[i, 0], tau_hat[i, 1], tau_hat[i, 2], t, lam, K1, K2, sat, phi, q1d_dot, q3d,
        )  # fmt: skip


@njit(inline="always")
def step(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """One sample of the packed law (:mod:`.packing`) for one robot: the observer's update
    with the torque held over the last sample (from the second sample on), then (3.49)-(3.50);
    ``F, G`` of (2.36) evaluated once, at this measurement, for both (the observer's held term
    for hold "end"; "start" and "trapezoid" use the previous sample's, kept in ``x``).
    Logs ``[S1, S2, tau_hat (3)]``."""
    m = np.int64(p[0])
    c = p[P_COEF[0] : P_COEF[1]]
    qd = (ym[0, 3], ym[0, 4], ym[0, 5])
    fg = model_terms(c, ym[0, 1], ym[0, 3], ym[0, 4], ym[0, 5])
    if m > 0 and k > 0:
        Phi = p[FIXED : FIXED + m * m].reshape((m, m))
        Gam = p[FIXED + m * m : FIXED + m * m + 3 * m].reshape((m, 3))
        z = x[X_Z : X_Z + m]
        qd_prev = (x[X_QD_PREV], x[X_QD_PREV + 1], x[X_QD_PREV + 2])
        f = x[X_FG_PREV : X_FG_PREV + 6]
        fg_prev = (f[0], f[1], f[2], f[3], f[4], f[5])
        hodo_sample(Phi, Gam, p[P_DECOUPLED] != 0.0, p[P_OBS_TS], np.int64(p[P_HOLD]), z,
                    qd_prev, qd, fg_prev, fg, x[X_U_PREV] + x[X_U_PREV + 1],
                    x[X_U_PREV] - x[X_U_PREV + 1],
                    x[X_Z + m : X_Z + 2 * m])  # fmt: skip
        for j in range(3):
            x[X_TH + j] = z[j]
    u[0, 0], u[0, 1], s1, s2 = smc_law(
        fg, ym[0, 0], ym[0, 1], ym[0, 2], ym[0, 3], ym[0, 4], ym[0, 5], x[X_TH], x[X_TH + 1],
        x[X_TH + 2], t, p[P_LAM[0] : P_LAM[1]], p[P_K1], p[P_K2], p[P_SAT] != 0.0, p[P_PHI],
        p[P_Q1D_DOT], p[P_Q3D],
    )  # fmt: skip
    for j in range(6):
        x[X_FG_PREV + j] = fg[j]
    for j in range(3):
        x[X_QD_PREV + j] = qd[j]
    x[X_U_PREV] = u[0, 0]
    x[X_U_PREV + 1] = u[0, 1]
    lg[0] = s1
    lg[1] = s2
    for j in range(3):
        lg[2 + j] = x[X_TH + j]
