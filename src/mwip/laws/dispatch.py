"""One sample of any packed law: the one place that dispatches on the law code.

Every compiled law (a folder of :mod:`mwip.laws`) has a kernel ``step(p, x, k, t, ym, u, lg)``
that reads its parameter vector ``p`` and state vector ``x`` (the layouts of its
``packing.py``, :mod:`mwip.laws.packing`), the sample index ``k`` and time ``t``, the
measurement ``ym`` (1, 8), and writes the torque ``u`` (1, 2) = ``[u_r, u_l]``, its state and
its log vector ``lg``. :func:`law_step` picks the kernel by code: the compiled closed loop
(:mod:`mwip.sim.loop`) and :class:`mwip.laws.batch.PackedController` (the Python loop, one
parameter vector per robot) both call it. A new compiled law adds one import and its branch
here (its kernel's files join :data:`mwip.jit_cache.SOURCES` by themselves).
"""

from __future__ import annotations

import numpy as np

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.asta import kernel as asta
from mwip.laws.fig53 import kernel as fig53
from mwip.laws.lqr import kernel as lqr
from mwip.laws.smc import kernel as smc
from mwip.laws.tsmc import kernel as tsmc

__all__ = ["law_step", "step_batch"]


@njit(inline="always")
def law_step(code, p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """One sample of the law ``code`` for one robot (module docstring)."""
    if code == lqr.CODE:
        lqr.step(p, x, k, t, ym, u, lg)
    elif code == smc.CODE:
        smc.step(p, x, k, t, ym, u, lg)
    elif code == tsmc.CODE:
        tsmc.step(p, x, k, t, ym, u, lg)
    elif code == asta.CODE:
        asta.step(p, x, k, t, ym, u, lg)
    elif code == fig53.CODE:
        fig53.step(p, x, k, t, ym, u, lg)


@njit
def step_batch(code, P, X, k, t, Y, U, LG):  # noqa: ANN001, ANN201 - compiled kernel
    """:func:`law_step` for a batch: robot ``i`` with parameters ``P[i]`` (or ``P[0]`` for
    all), state ``X[i]``, measurement ``Y[i]`` (N, 8); fills ``U`` (N, 2) and ``LG`` (N, w)."""
    ym = np.empty((1, 8))
    u = np.empty((1, 2))
    for i in range(Y.shape[0]):
        for j in range(8):
            ym[0, j] = Y[i, j]
        p = P[i if P.shape[0] > 1 else 0]
        law_step(code, p, X[i], k, t, ym, u, LG[i])
        U[i, 0] = u[0, 0]
        U[i, 1] = u[0, 1]
