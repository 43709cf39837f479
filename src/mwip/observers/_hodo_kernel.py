"""Compiled sample update of the high-order disturbance observer (3.20)-(3.23).

The one implementation of :meth:`mwip.observers.hodo.HighOrderDO.update` for the default
model (the closed forms of (2.36) on one robot's nominal coefficients): the held model term
``f_k = F + G [u_A, u_B]`` at the state chosen by ``hold``, the measured disturbance
``d_k = (q'_{k+1} - q'_k) / Ts - f_k`` and ``z_{k+1} = Phi z_k + Gamma d_k`` (see
:mod:`mwip.observers.hodo` for the discretisation). The compiled closed loop
(:mod:`mwip.sim.loop`) calls the same kernel.
"""

from __future__ import annotations

import numba

from mwip.models._compiled import f_g_scalar

#: ``hold`` codes: where ``F, G`` are evaluated over a sample.
HOLD_START, HOLD_END, HOLD_TRAPEZOID = 0, 1, 2
HOLD_CODES = {"start": HOLD_START, "end": HOLD_END, "trapezoid": HOLD_TRAPEZOID}


@numba.njit(cache=True, inline="always")
def _fgu(c, q, qd, uA, uB):  # noqa: ANN001, ANN202 - compiled kernel
    f1, f2, f3, g1, g2, g3 = f_g_scalar(
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], q[1], qd[0], qd[1], qd[2]
    )
    return f1 + g1 * uA, f2 + g2 * uA, f3 + g3 * uB


@numba.njit(cache=True)
def hodo_update(c, Phi, Gam, Ts, hold, z, q_prev, qd_prev, q, qd, u, work):  # noqa: ANN001, ANN201
    """Advance ``z`` (N, 3n) over one sample in place and store ``q, qd`` as the previous
    measurement (``q_prev, qd_prev`` (N, 3), updated in place).

    ``c`` (10,) nominal coefficients; ``Phi`` (3n, 3n), ``Gam`` (3n, 3); ``hold`` one of
    :data:`HOLD_CODES`; ``q, qd`` (N, 3) the new measurement; ``u`` (N, 2) ``[u_r, u_l]`` held
    over the sample just ended; ``work`` (3n,) scratch space.
    """
    m = z.shape[1]
    znew = work
    for i in range(z.shape[0]):
        uA = u[i, 0] + u[i, 1]
        uB = u[i, 0] - u[i, 1]
        if hold == HOLD_START:
            f0, f1, f2 = _fgu(c, q_prev[i], qd_prev[i], uA, uB)
        elif hold == HOLD_END:
            f0, f1, f2 = _fgu(c, q[i], qd[i], uA, uB)
        else:
            a0, a1, a2 = _fgu(c, q_prev[i], qd_prev[i], uA, uB)
            b0, b1, b2 = _fgu(c, q[i], qd[i], uA, uB)
            f0, f1, f2 = 0.5 * (a0 + b0), 0.5 * (a1 + b1), 0.5 * (a2 + b2)
        d0 = (qd[i, 0] - qd_prev[i, 0]) / Ts - f0
        d1 = (qd[i, 1] - qd_prev[i, 1]) / Ts - f1
        d2 = (qd[i, 2] - qd_prev[i, 2]) / Ts - f2
        # z <- Gamma d + Phi z, summed in the order b = 0 .. m-1 for every row; the loop over
        # rows innermost keeps the m sums independent (no chain of m dependent additions)
        for a in range(m):
            znew[a] = Gam[a, 0] * d0 + Gam[a, 1] * d1 + Gam[a, 2] * d2
        for b in range(m):
            zb = z[i, b]
            for a in range(m):
                znew[a] += Phi[a, b] * zb
        for a in range(m):
            z[i, a] = znew[a]
        for j in range(3):
            q_prev[i, j] = q[i, j]
            qd_prev[i, j] = qd[i, j]
