"""The compiled closed loop: a whole sampled run of each robot inside one compiled function.

The Python loop of :func:`mwip.sim.engine.simulate` pays the interpreter at every sample
(measurement, controller call, logs, kernel dispatch): for a single run that was ~80 % of the
time. When the controller offers its law as a :class:`mwip.core.CompiledLaw` (the registered
LQR, sliding-mode family and fuzzy controllers do) and the loop is the plain one (ideal
sensor, no actuator model), :func:`run` does the same sequence per robot in compiled code::

    for k = 0 .. n_samples:                 # t_k = k Ts
        u = law(t_k, y)                      # the controller's own compiled kernel
        record y, u, logs if k is recorded
        advance the plant Ts/dt steps with u held (kernel.step_one: ROS2-W or RK4)
        stop on the events "fell" / "diverged"

with the controller's state (observer, previous torque) in small arrays. The laws keep one
implementation: the loop calls :func:`mwip.control._lqr_kernel.lqr_law`,
:func:`mwip.control._tsmc_kernel.tsmc_step`, the ASTA kernels, and for the sliding-mode
family the per-robot cores :func:`mwip.control._smc_kernel.smc_law` and
:func:`mwip.observers._hodo_kernel.hodo_sample` of ``smc_step`` and ``hodo_update``, the
kernels behind the Python classes, with the same numbers in the same order, so both paths
agree to round-off (tests/test_loop.py). The sliding-mode branch evaluates ``F, G`` of (2.36)
once per sample, at the measurement, for both the observer's held model term and the law
(the Python classes each evaluate them at the same measurement: the same numbers), and keeps
the previous sample's for the observer's ``"start"``/``"trapezoid"`` holds.
The fuzzy law of Fig. 5.3 (it2, t1) calls :func:`mwip.fuzzy._fig53_kernel.fig53_law`.

Batches: robots are independent, so :func:`run_parallel` spreads them over threads
(``prange``) with one barrier at the end of the run rather than one per sample.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mwip.control._asta_kernel import asta_sample, asta_terms
from mwip.control._lqr_kernel import lqr_law
from mwip.control._smc_kernel import smc_law
from mwip.control._tsmc_kernel import tsmc_step
from mwip.core import LAW_ASTA, LAW_FUZZY, LAW_LINEAR, LAW_TSMC
from mwip.fuzzy._fig53_kernel import fig53_law
from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.observers._hodo_kernel import channels_decoupled, hodo_sample, model_terms
from mwip.sim.codes import PARALLEL_MIN
from mwip.sim.kernel import DIVERGED, FELL, OK, step_one

__all__ = ["run", "run_parallel", "PARALLEL_MIN"]

_FELL_ANGLE = 0.5 * math.pi


# _run_one takes some arrays in tuples: CPython compiles a call with more than 30 positional
# arguments to a *args call, which numba cannot inline
@njit(inline="always")
def _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx,  # noqa: ANN001, ANN202, PLR0913
             kind, gain, offset, c_nom, lam, sc, Phi, Gam, obs, tC, tGam, tD, tIDinv, refs, cubic,
             fuzzy, out, status, t_end):  # fmt: skip
    frows, fls = fuzzy
    states, us, logs = out
    yi = y[i]
    c = coef[i if coef.shape[0] > 1 else 0]
    ti = i if tau.shape[2] > 1 else 0
    m = Phi.shape[0]
    ym = np.empty((1, 8))
    q1 = np.empty((1, 3))
    qd1 = np.empty((1, 3))
    th = np.zeros((1, 3))
    u1 = np.zeros((1, 2))
    S1 = np.zeros((1, 2))
    z = np.zeros(m)
    work = np.empty(m)
    qd_prev = (yi[3], yi[4], yi[5])  # the previous measurement's rates and F, G terms
    fg_prev = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # (set by the law at every sample)
    decoupled = channels_decoupled(Phi, Gam)
    obs_Ts = obs[0] if m > 0 else 1.0
    hold = np.int64(obs[1]) if m > 0 else np.int64(0)
    sat = sc[2] != 0.0
    s2 = np.zeros((1, 2))
    k2 = np.zeros((1, 2))
    a2 = np.zeros((1, 2))
    ci = i if cubic.shape[0] > 1 else 0
    cub = cubic[ci : ci + 1]
    g_st = np.zeros((1, 2))  # ASTA/ASMC: adaptive gains from Gamma0 (offset), w from zero
    g_st[0, 0] = offset[0]
    g_st[0, 1] = offset[1]
    w_st = np.zeros((1, 2))
    g_log = np.zeros((1, 2))
    w_log = np.zeros((1, 2))
    th_off = np.zeros(1)  # the fuzzy law's logs
    u_alpha = np.zeros(1)
    row = 0
    n_rec = rec_idx.shape[0]
    stopped = False
    for k in range(n_samples + 1):
        t = k * Ts
        for j in range(8):
            ym[0, j] = yi[j]
        if kind == LAW_LINEAR:
            lqr_law(ym, gain, offset, u1)
        elif kind == LAW_ASTA:
            for j in range(3):
                q1[0, j] = ym[0, j]
                qd1[0, j] = ym[0, 3 + j]
            asta_terms(c_nom, q1, qd1, lam, refs, s2, k2, a2)  # sigma, a, b
            for j in range(2):  # logged before the update, as the Python class does
                g_log[0, j] = g_st[0, j]
                w_log[0, j] = w_st[0, j]
            asta_sample(k2, a2, s2, tC, tGam, sc[0], sc[1], sc[2] != 0.0, g_st, w_st, u1)
        elif kind == LAW_FUZZY:
            fig53_law(ym, frows, fls, i, u1, th_off, u_alpha)
        elif kind == LAW_TSMC:
            for j in range(3):
                q1[0, j] = ym[0, j]
                qd1[0, j] = ym[0, 3 + j]
            tsmc_step(c_nom, q1, qd1, t, t - sc[4], cub, sc[0], tC, sc[1], tD, tIDinv, tGam, sat,
                      sc[3], refs, u1, s2, k2, a2)  # fmt: skip
        else:
            # F, G of (2.36) at this measurement, once: the observer's held model term
            # (hold "end"; "start" uses the previous sample's) and the law's
            qd = (yi[3], yi[4], yi[5])
            fg = model_terms(c_nom, yi[1], yi[3], yi[4], yi[5])
            if m > 0 and k > 0:  # observer first, with the torque held over the last sample
                hodo_sample(Phi, Gam, decoupled, obs_Ts, hold, z, qd_prev, qd, fg_prev, fg,
                            u1[0, 0] + u1[0, 1], u1[0, 0] - u1[0, 1], work)  # fmt: skip
                for j in range(3):
                    th[0, j] = z[j]
            u1[0, 0], u1[0, 1], S1[0, 0], S1[0, 1] = smc_law(
                fg, yi[0], yi[1], yi[2], yi[3], yi[4], yi[5], th[0, 0], th[0, 1], th[0, 2], t,
                lam, sc[0], sc[1], sat, sc[3], sc[4], sc[5],
            )  # fmt: skip
            fg_prev, qd_prev = fg, qd
        if row < n_rec and rec_idx[row] == k:
            for j in range(8):
                states[i, row, j] = yi[j]
            us[i, row, 0] = u1[0, 0]
            us[i, row, 1] = u1[0, 1]
            if kind == LAW_ASTA:
                for j in range(2):
                    logs[i, row, j] = s2[0, j]
                    logs[i, row, 2 + j] = g_log[0, j]
                    logs[i, row, 4 + j] = w_log[0, j]
            elif kind == LAW_FUZZY:
                logs[i, row, 0] = th_off[0]
                logs[i, row, 1] = u_alpha[0]
            elif kind == LAW_TSMC:
                for j in range(2):
                    logs[i, row, j] = s2[0, j]
                    logs[i, row, 2 + j] = k2[0, j]
                    logs[i, row, 4 + j] = a2[0, j]
            elif logs.shape[2] == 5:
                logs[i, row, 0] = S1[0, 0]
                logs[i, row, 1] = S1[0, 1]
                for j in range(3):
                    logs[i, row, 2 + j] = th[0, j]
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
def run(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx,  # noqa: ANN001, ANN201, PLR0913
        kind, gain, offset, c_nom, lam, sc, Phi, Gam, obs, tC, tGam, tD, tIDinv, refs, cubic,
        frows, fls, states, us, logs, status, t_end):  # fmt: skip
    """Run every robot's closed loop to the end, one after the other; returns the robots
    still running.

    ``y`` (N, 8) initial states (updated in place to the final ones); ``coef`` (1 or N, 10)
    plant coefficients; ``tau`` (1 or n_samples, S, 1 or N, 3) external forces per sample at
    the step boundaries (ROS2-W, S = n_sub + 1) or half steps (RK4, S = 2 n_sub + 1);
    ``method``, ``h``, ``n_sub`` as :func:`mwip.sim.kernel.advance`; ``rec_idx`` the recorded
    sample indices; a stopped robot is recorded at the next sample instant (kept by the engine
    when it stopped exactly there) and then left. The law's arguments are the fields of
    :class:`mwip.core.CompiledLaw`.
    ``states`` (N, R, 8), ``us`` (N, R, 2), ``logs`` (N, R, the law's log width) are filled at the
    recorded samples (left as they are elsewhere); ``status``, ``t_end`` (N,) as the kernel.
    """
    running = 0
    for i in range(y.shape[0]):
        _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, kind, gain,
                 offset, c_nom, lam, sc, Phi, Gam, obs, tC, tGam, tD, tIDinv, refs, cubic,
                 (frows, fls), (states, us, logs), status, t_end)  # fmt: skip
        running += status[i] == OK
    return running


@njit(parallel=True)
def run_parallel(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx,  # noqa: ANN001, ANN201, PLR0913
                 kind, gain, offset, c_nom, lam, sc, Phi, Gam, obs, tC, tGam, tD, tIDinv, refs,
                 cubic, frows, fls, states, us, logs, status, t_end):  # fmt: skip
    """:func:`run` with the robots spread over threads: one barrier, at the end of the run."""
    for i in numba.prange(y.shape[0]):
        _run_one(np.int64(i), y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx,
                 kind, gain, offset, c_nom, lam, sc, Phi, Gam, obs, tC, tGam, tD, tIDinv, refs,
                 cubic, (frows, fls), (states, us, logs), status, t_end)  # fmt: skip
    running = 0
    for i in range(y.shape[0]):
        running += status[i] == OK
    return running
