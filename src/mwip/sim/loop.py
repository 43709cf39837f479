"""The compiled closed loop: a whole sampled run of each robot inside one compiled function.

The Python loop of :func:`mwip.sim.engine.simulate` pays the interpreter at every sample
(measurement, controller call, logs, kernel dispatch): for a single run that was ~80 % of the
time. When the controller offers its law packed (:meth:`packed_law`, a
:class:`mwip.laws.packing.PackedLaw`: the registered LQR, sliding-mode family, TSMC, ASTA/ASMC
and fuzzy controllers do) and the loop is the plain one (ideal sensor, no actuator model),
:func:`run` does the same sequence per robot in compiled code::

    for k = 0 .. n_samples:                 # t_k = k Ts
        u = law_step(code, p, x, k, t_k, y)  # the law's own kernel (mwip.laws.dispatch)
        record y, u, logs if k is recorded
        advance the plant Ts/dt steps with u held (kernel.step_one: ROS2-W or RK4)
        stop on the events "fell" / "diverged"

with ``p`` the law's parameter vector (one for the batch, or one per robot), ``x`` its state
vector (observer, adaptive gains, previous torque). Every law has one implementation, its
folder's kernel, which the Python controller calls too, with the same numbers in the same
order, so both paths agree to round-off (tests/test_loop.py).

One fixed signature for every law: the plant, the run's sizes, the law code and the packed
vectors ``P`` (1 or N, n_p), ``X`` (N, n_x), the record arrays.

Batches: robots are independent, so :func:`run_parallel` spreads them over threads
(``prange``) with one barrier at the end of the run rather than one per sample.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.dispatch import law_step
from mwip.sim.codes import PARALLEL_MIN
from mwip.sim.kernel import DIVERGED, FELL, OK, step_one

__all__ = ["run", "run_parallel", "PARALLEL_MIN"]

_FELL_ANGLE = 0.5 * math.pi


@njit(inline="always")
def _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X,  # noqa: ANN001, ANN202, PLR0913
             states, us, logs, status, t_end):  # fmt: skip
    yi = y[i]
    c = coef[i if coef.shape[0] > 1 else 0]
    ti = i if tau.shape[2] > 1 else 0
    p = P[i if P.shape[0] > 1 else 0]
    x = X[i]
    ym = np.empty((1, 8))
    u1 = np.zeros((1, 2))
    lg = np.zeros(logs.shape[2])
    row = 0
    n_rec = rec_idx.shape[0]
    stopped = False
    for k in range(n_samples + 1):
        t = k * Ts
        for j in range(8):
            ym[0, j] = yi[j]
        law_step(code, p, x, k, t, ym, u1, lg)
        if row < n_rec and rec_idx[row] == k:
            for j in range(8):
                states[i, row, j] = yi[j]
            us[i, row, 0] = u1[0, 0]
            us[i, row, 1] = u1[0, 1]
            for j in range(lg.shape[0]):
                logs[i, row, j] = lg[j]
            row += 1
        if k == n_samples or stopped:
            break
        tk = tau[k if tau.shape[0] > 1 else 0]
        ur, ul = u1[0, 0], u1[0, 1]
        for s in range(n_sub):
            step_one(yi, ur, ul, tk, s, ti, c, h, method)
            finite = True
            for j in range(8):
                if not math.isfinite(yi[j]):
                    finite = False
            if not finite or abs(yi[1]) >= _FELL_ANGLE:
                status[i] = DIVERGED if not finite else FELL
                t_end[i] = t + (s + 1) * h
                stopped = True
                break


@njit
def run(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, states, us, logs,  # noqa: ANN001, ANN201, PLR0913
        status, t_end):  # fmt: skip
    """Run every robot's closed loop to the end, one after the other; returns the robots
    still running.

    ``y`` (N, 8) initial states (updated in place to the final ones); ``coef`` (1 or N, 10)
    plant coefficients; ``tau`` (1 or n_samples, S, 1 or N, 3) external forces per sample at
    the step boundaries (ROS2-W, S = n_sub + 1) or half steps (RK4, S = 2 n_sub + 1);
    ``method``, ``h``, ``n_sub`` as :func:`mwip.sim.kernel.advance`; ``rec_idx`` the recorded
    sample indices; a stopped robot is recorded at the next sample instant (kept by the engine
    when it stopped exactly there) and then left. ``code`` the law
    (:mod:`mwip.laws.dispatch`), ``P`` (1 or N, n_p) its parameter vectors, ``X`` (N, n_x) its
    state vectors (updated in place) (:class:`mwip.laws.packing.PackedLaw`).
    ``states`` (N, R, 8), ``us`` (N, R, 2), ``logs`` (N, R, the law's log width) are filled at the
    recorded samples (left as they are elsewhere); ``status``, ``t_end`` (N,) as the kernel.
    """
    running = 0
    for i in range(y.shape[0]):
        _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, states,
                 us, logs, status, t_end)  # fmt: skip
        running += status[i] == OK
    return running


@njit(parallel=True)
def run_parallel(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, states,  # noqa: ANN001, ANN201, PLR0913
                 us, logs, status, t_end):  # fmt: skip
    """:func:`run` with the robots spread over threads: one barrier, at the end of the run."""
    for i in numba.prange(y.shape[0]):
        _run_one(np.int64(i), y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P,
                 X, states, us, logs, status, t_end)  # fmt: skip
    running = 0
    for i in range(y.shape[0]):
        running += status[i] == OK
    return running
