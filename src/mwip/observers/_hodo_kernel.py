"""Compiled sample update of the high-order disturbance observer (3.20)-(3.23).

The one implementation of :meth:`mwip.observers.hodo.HighOrderDO.update` for the default
model (the closed forms of (2.36) on one robot's nominal coefficients): the held model term
``f_k = F + G [u_A, u_B]`` at the state chosen by ``hold``, the measured disturbance
``d_k = (q'_{k+1} - q'_k) / Ts - f_k`` and ``z_{k+1} = Phi z_k + Gamma d_k`` (see
:mod:`mwip.observers.hodo` for the discretisation).

:func:`hodo_update` is the batch entry point of the Python class; the compiled closed loop
(:mod:`mwip.sim.loop`) calls its per-robot core :func:`hodo_sample` with the terms ``F, G``
it has already evaluated for the law at the same measurements (the same numbers, computed
once), so both paths run the same arithmetic.

Structure of ``Phi, Gamma``: with gains ``L_i`` that are diagonal (the book's ``v_i I3``
among them) the three channels ``psi, theta, alpha`` of ``z = [tau^, tau^', ...]`` never
mix: ``D_n`` of (3.31) and ``Lc`` couple only entries of one channel, so do ``expm`` and its
integral, and every entry ``Phi[a, b]`` with ``a mod 3 != b mod 3`` (``Gamma[a, j]`` with
``a mod 3 != j``) is an exact zero. :func:`observer_step` then skips those terms (a third of
the products for n = 4): each row is summed in the same order over the terms it keeps, and
the terms skipped are exact zeros, so the result equals the dense product's.
"""

from __future__ import annotations

import numpy as np

from mwip.core import HOLD_CODES, HOLD_END, HOLD_START, HOLD_TRAPEZOID  # noqa: F401 - re-exported
from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.models._compiled import f_g_scalar


@njit(inline="always")
def model_terms(c, th, psid, thd, ald):  # noqa: ANN001, ANN201 - compiled kernel
    """``(f1, f2, f3, g1, g2, g3)`` of (2.36) on the coefficients ``c`` (10,) at one robot's
    pitch ``theta`` and rates ``psi', theta', alpha'``."""
    return f_g_scalar(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], th, psid, thd,
                      ald)  # fmt: skip


@njit(inline="always")
def _fgu(fg, uA, uB):  # noqa: ANN001, ANN202 - compiled kernel
    """``F + G [u_A, u_B]`` of (2.36) from the terms ``fg = (f1, f2, f3, g1, g2, g3)``."""
    return fg[0] + fg[3] * uA, fg[1] + fg[4] * uA, fg[2] + fg[5] * uB


@njit(inline="always")
def channels_decoupled(Phi, Gam):  # noqa: ANN001, ANN201 - compiled kernel
    """True when no entry couples two channels: ``Phi[3i + ca, 3j + cb] = 0`` and
    ``Gam[3i + ca, cb] = 0`` for every ``ca != cb`` (module docstring)."""
    n = Phi.shape[0] // 3
    for ca in range(3):
        for cb in range(3):
            if ca == cb:
                continue
            for i in range(n):
                row = np.uint64(3 * i + ca)
                if Gam[row, cb] != 0.0:
                    return False
                for j in range(n):
                    if Phi[row, np.uint64(3 * j + cb)] != 0.0:
                        return False
    return True


@njit(inline="always")
def observer_step(Phi, Gam, decoupled, z, d0, d1, d2, work):  # noqa: ANN001, ANN201, PLR0913
    """``z <- Phi z + Gam [d0, d1, d2]`` in place on one robot's ``z`` (3n,), ``work`` (3n,)
    scratch; ``decoupled`` from :func:`channels_decoupled` (its zeros are skipped).

    Every row is ``Gam d`` (terms j = 0, 1, 2) plus ``Phi[a, b] z[b]`` for b = 0 .. 3n-1, in
    that order."""
    m = z.shape[0]
    if decoupled:  # row 3i + ch of channel ch: its terms b = 3j + ch, j = 0 .. n-1
        n = m // 3
        for i in range(n):  # three independent sums (the channels) per block row
            a = np.uint64(3 * i)  # unsigned: no wrap-around of negative indices to emit
            acc0 = Gam[a, 0] * d0
            acc1 = Gam[a + 1, 1] * d1
            acc2 = Gam[a + 2, 2] * d2
            for j in range(n):
                b = np.uint64(3 * j)
                acc0 += Phi[a, b] * z[b]
                acc1 += Phi[a + 1, b + 1] * z[b + 1]
                acc2 += Phi[a + 2, b + 2] * z[b + 2]
            work[a] = acc0
            work[a + 1] = acc1
            work[a + 2] = acc2
    else:
        # the loop over rows innermost keeps the m sums independent (no chain of m
        # dependent additions)
        for row in range(m):
            work[row] = Gam[row, 0] * d0 + Gam[row, 1] * d1 + Gam[row, 2] * d2
        for col in range(m):
            zc = z[col]
            for row in range(m):
                work[row] += Phi[row, col] * zc
    for row in range(m):
        z[row] = work[row]


@njit(inline="always")
def hodo_sample(Phi, Gam, decoupled, Ts, hold, z, qd_prev, qd, fg_prev, fg, uA, uB, work):  # noqa: ANN001, ANN201, PLR0913
    """One robot's sample (3.20)-(3.23), discretised: ``z`` (3n,) advanced in place.

    ``fg_prev, fg``: the terms of (2.36) (:func:`model_terms`) at the previous and the new
    measurement; ``qd_prev, qd`` the measured rates there (3-tuples); ``u_A, u_B`` the torque held
    over the sample. ``f_k`` is ``F + G u`` at the start, the end or their mean (``hold``),
    ``d_k = (q'_{k+1} - q'_k) / Ts - f_k``, then :func:`observer_step`.
    """
    if hold == HOLD_START:
        f0, f1, f2 = _fgu(fg_prev, uA, uB)
    elif hold == HOLD_END:
        f0, f1, f2 = _fgu(fg, uA, uB)
    else:
        a0, a1, a2 = _fgu(fg_prev, uA, uB)
        b0, b1, b2 = _fgu(fg, uA, uB)
        f0, f1, f2 = 0.5 * (a0 + b0), 0.5 * (a1 + b1), 0.5 * (a2 + b2)
    d0 = (qd[0] - qd_prev[0]) / Ts - f0
    d1 = (qd[1] - qd_prev[1]) / Ts - f1
    d2 = (qd[2] - qd_prev[2]) / Ts - f2
    observer_step(Phi, Gam, decoupled, z, d0, d1, d2, work)


@njit
def hodo_update(c, Phi, Gam, Ts, hold, z, q_prev, qd_prev, q, qd, u, work):  # noqa: ANN001, ANN201
    """Advance ``z`` (N, 3n) over one sample in place and store ``q, qd`` as the previous
    measurement (``q_prev, qd_prev`` (N, 3), updated in place).

    ``c`` (10,) nominal coefficients; ``Phi`` (3n, 3n), ``Gam`` (3n, 3); ``hold`` one of
    :data:`HOLD_CODES`; ``q, qd`` (N, 3) the new measurement; ``u`` (N, 2) ``[u_r, u_l]`` held
    over the sample just ended; ``work`` (3n,) scratch space. Per robot :func:`hodo_sample`.
    """
    decoupled = channels_decoupled(Phi, Gam)
    for i in range(z.shape[0]):
        fg = model_terms(c, q[i, 1], qd[i, 0], qd[i, 1], qd[i, 2])
        fg_prev = (
            fg if hold == HOLD_END
            else model_terms(c, q_prev[i, 1], qd_prev[i, 0], qd_prev[i, 1], qd_prev[i, 2])
        )  # fmt: skip
        hodo_sample(Phi, Gam, decoupled, Ts, hold, z[i], (qd_prev[i, 0], qd_prev[i, 1],
                    qd_prev[i, 2]), (qd[i, 0], qd[i, 1], qd[i, 2]), fg_prev, fg,
                    u[i, 0] + u[i, 1], u[i, 0] - u[i, 1], work)  # fmt: skip
        for j in range(3):
            q_prev[i, j] = q[i, j]
            qd_prev[i, j] = qd[i, j]
