"""Compiled Fig. 5.3 fuzzy law: the PDC balance law (5.10) with the membership grades of
Fig. 5.1 / (5.7)-(5.8) and the position and direction Mamdani FLSs of Section 5.3.2
(:mod:`mwip.fuzzy._kernel` evaluates them), one robot per row of a batch.

The one implementation of :meth:`mwip.laws.fig53.controller.Fig53Controller.__call__`; the
compiled closed loop (:mod:`mwip.sim.loop`) calls :func:`step` on the packed law
(:mod:`.packing`), which calls :func:`fig53_law` with the same arguments. Its NumPy oracle is
in tests/oracle_laws.py; tests/test_kernels.py holds the two equal on random inputs and
benchmarks/mutate_kernels.py checks that a sign flip here fails them.

The PDC sum ``sum_ij m_i G_ij x_j`` is accumulated ``i`` outer, ``j`` inner from zero (NumPy's
``einsum`` took that order for batches of 3 or more robots; for one robot, and two sharing one
design, it grouped the sum by ``i``, so those runs differ from the former NumPy law in the last
bit of ``u``).
"""

from __future__ import annotations

import numpy as np

from mwip.fuzzy._kernel import fls_eval, pdc_weights
from mwip.fuzzy.layout import ROW_WIDTH
from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.fig53.packing import (
    CODE,  # noqa: F401 - the dispatcher reads kernel.CODE
    P_FLS,
    P_ROW,
)

__all__ = ["ROW_WIDTH", "fig53_law", "step"]


@njit
def fig53_law(y, rows, fls, first, u, theta_off, u_alpha):  # noqa: ANN001, ANN201
    """The Fig. 5.3 law for a batch: ``u`` (N, 2) = ``[u_r, u_l]``, ``theta_off``, ``u_alpha``
    (N,) from the measurements ``y`` (N, 8).

    Robot ``k`` uses the row ``first + k`` of ``rows`` (R, :data:`ROW_WIDTH`), or row 0 when
    ``R == 1``; its kind ``c`` (0 IT2, 1 type 1) picks the position FLS ``fls[c]`` and the
    direction FLS ``fls[2 + c]``. Term by term (Section 5.3.2, Fig. 5.3)::

        theta_off = FLS_p(r_nom psi - p_d, theta')        (0 without a position target)
        u_alpha   = FLS_alpha(alpha - alpha_d, alpha')     (0 without a heading target)
        x         = [theta - theta_off, theta', psi (0 with a position target), psi']
        u_p       = (1/2) sum_i m_i(theta) G_i x           (5.10)
        u         = [u_p + u_alpha, u_p - u_alpha]
    """
    mem = np.empty((4, fls.shape[1]))
    fr = np.empty((4, fls.shape[1]))
    single = rows.shape[0] == 1
    for k in range(y.shape[0]):
        row = rows[0] if single else rows[first + k]
        c = int(row[0])
        th_off = 0.0
        ua = 0.0
        if row[11] != 0.0:
            th_off = fls_eval(row[13] * y[k, 0] - row[9], y[k, 4], fls[c], mem, fr)
        if row[12] != 0.0:
            ua = fls_eval(y[k, 2] - row[10], y[k, 5], fls[2 + c], mem, fr)
        m1, m2 = pdc_weights(y[k, 1], c == 1)
        x0 = y[k, 1] - th_off
        x2 = 0.0 if row[11] != 0.0 else y[k, 0]
        acc = 0.0
        acc += (m1 * row[1]) * x0
        acc += (m1 * row[2]) * y[k, 4]
        acc += (m1 * row[3]) * x2
        acc += (m1 * row[4]) * y[k, 3]
        acc += (m2 * row[5]) * x0
        acc += (m2 * row[6]) * y[k, 4]
        acc += (m2 * row[7]) * x2
        acc += (m2 * row[8]) * y[k, 3]
        up = 0.5 * acc
        u[k, 0] = up + ua
        u[k, 1] = up - ua
        theta_off[k] = th_off
        u_alpha[k] = ua


@njit(inline="always")
def step(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201, ARG001 - compiled kernel
    """One sample of the packed law (:mod:`.packing`) for one robot: :func:`fig53_law` with
    this robot's row. Logs ``[theta_off, u_alpha]``."""
    L = np.int64(p[0])
    th_off = x[0:1]
    u_alpha = x[1:2]
    fig53_law(ym, p[P_ROW : P_ROW + ROW_WIDTH].reshape((1, ROW_WIDTH)),
              p[P_FLS : P_FLS + 4 * L].reshape((4, L)), 0, u, th_off, u_alpha)  # fmt: skip
    lg[0] = th_off[0]
    lg[1] = u_alpha[0]
