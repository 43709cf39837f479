"""Compiled evaluation of the linear state feedback ``u = -K (x - x_ref)`` (Sec. 4.4.2).

The one implementation of the LQR law (:class:`mwip.laws.lqr.controller.LQR` and the compiled
closed loop :mod:`mwip.sim.loop` call it). The selection of ``x = [theta, alpha, theta', v,
alpha']`` from the measured ``y[:6]`` (with ``v = r_nom psi'``) is folded into ``gain``
(6, 2) and the reference into ``offset`` (2,), so ``u = y[:6] @ gain + offset``.
"""

from __future__ import annotations

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.lqr.packing import (
    CODE,  # noqa: F401 - the dispatcher reads kernel.CODE
    GAIN,
    OFFSET,
)


@njit
def lqr_law(y, gain, offset, u):  # noqa: ANN001, ANN201 - compiled kernel
    """Fill ``u`` (N, 2) with ``y[:, :6] @ gain + offset`` for measurements ``y`` (N, >= 6)."""
    for i in range(y.shape[0]):
        for j in range(2):
            acc = offset[j]
            for a in range(6):
                acc += y[i, a] * gain[a, j]
            u[i, j] = acc
    return u


@njit(inline="always")
def step(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201, ARG001 - compiled kernel
    """One sample of the packed law (:mod:`.packing`) for one robot: ``u`` (1, 2) from the
    measurement ``ym`` (1, 8); no state, no logs."""
    lqr_law(ym, p[GAIN[0] : GAIN[1]].reshape((6, 2)), p[OFFSET[0] : OFFSET[1]], u)
