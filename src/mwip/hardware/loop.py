"""The twin's closed loop compiled: sensor chain, packed law, drive chain and plant per sample.

For each robot of a batch, in compiled code::

    for k = 0 .. n_samples:                  # t_k = k Ts
        y_m = sensor chain(y)                # k = 0: the engine's own first measurement
        u = law_step(code, p, x, k, t_k, y_m)
        u_a = drive chain(u, y)              # command disturbances, delay, firmware,
                                             # motors and driver, friction, backlash
        record y, u, the law's logs, u_a, the elements' logs if k is recorded
        advance the plant Ts/dt steps with u_a held; stop on "fell" / "diverged"

The chains are the elements of :mod:`mwip.hardware.registry` that run for this batch, packed
by :mod:`mwip.hardware.pack` (a *plan*: one row per element, its code and the spans of its
parameters, state, noise variates and logs) and stepped by :func:`mwip.hardware.dispatch.
element_step`: the elements' one implementation. :func:`sense_batch` and :func:`drive_batch`
step the same chains for a whole batch at one sample, for the engine's Python loop (a
controller without a packed law, ``simulate(..., compiled=False)``): both paths run the same
compiled arithmetic in the same order, so they agree bit for bit (tests/test_twin_loop.py).

The elements' normal variates (the IMU's, and the command noise of ``mwip bench``) come in
chunks ``Z`` (samples, variates, 1 or N): drawn before each chunk of samples from the run's
noise sources (:mod:`mwip.hardware.twin`), one column per robot or one for all.

The engine finds this loop through :meth:`mwip.hardware.twin.TwinSensor.compiled_loop`; the
engine imports no hardware.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mwip.hardware.bus import BUS, B
from mwip.hardware.dispatch import element_step
from mwip.jit_cache import njit
from mwip.laws.dispatch import law_step
from mwip.sim.kernel import DIVERGED, FELL, OK, step_one

__all__ = ["run", "run_parallel", "sense_batch", "drive_batch", "CHUNK_NUMBERS"]

_FELL_ANGLE = 0.5 * math.pi
_BUS = BUS.size

#: Numbers of disturbance and noise variates tabulated per chunk of samples (a long run or a
#: large batch runs in consecutive chunks of samples).
CHUNK_NUMBERS = 4_000_000


@njit(inline="always")
def _chain(k, yi, P, X, plan, bus, Z, kz, zi, zs, lg, ls):  # noqa: ANN001, ANN202, PLR0913
    """The elements of ``plan`` in order, for one robot at sample ``k``: its parameters
    ``P``, state ``X``, the noise row ``Z[kz, zs + ..., zi]`` and logs ``lg[ls + ...]``."""
    for e in range(plan.shape[0]):
        c = plan[e]
        element_step(c[0], k, P[c[1] : c[2]], X[c[3] : c[4]], bus, yi,
                     Z[kz, zs + c[5] : zs + c[6], zi], lg[ls + c[7] : ls + c[8]])  # fmt: skip


@njit(inline="always")
def _sense(k, yi, P, X, plan, bus, Z, kz, zi, lg, ym):  # noqa: ANN001, ANN202, PLR0913
    """The sensor chain: the measurement ``ym`` (1, 8) of the true state ``yi``."""
    for j in range(8):
        bus[B.ym + j] = yi[j]
    bus[B.theta_hat] = yi[1]
    bus[B.rate_hat] = yi[4]
    _chain(k, yi, P, X, plan, bus, Z, kz, zi, 0, lg, 0)
    for j in range(8):
        ym[0, j] = bus[B.ym + j]


@njit(inline="always")
def _drive(k, yi, u0, u1, P, X, plan, bus, Z, kz, zi, zs, lg, ls, ua):  # noqa: ANN001, ANN202, PLR0913
    """The drive chain: the torques ``ua`` (2,) held over the sample for the command."""
    bus[B.u] = u0
    bus[B.u + 1] = u1
    _chain(k, yi, P, X, plan, bus, Z, kz, zi, zs, lg, ls)
    ua[0] = bus[B.u]
    ua[1] = bus[B.u + 1]


@njit
def sense_batch(k, Y, P, X, plan, Z, LG, YM):  # noqa: ANN001, ANN201, PLR0913
    """The sensor chain for every robot at sample ``k``: true states ``Y`` (N, 8), the
    chain's parameters ``P`` (1 or N, .) and states ``X`` (N, .), ``Z`` (1, variates, 1 or N)
    this sample's noise, logs ``LG`` (N, w) and measurements ``YM`` (N, 8) written."""
    bus = np.zeros(_BUS)
    ym = np.empty((1, 8))
    for i in range(Y.shape[0]):
        _sense(k, Y[i], P[i if P.shape[0] > 1 else 0], X[i], plan, bus, Z, 0,
               i if Z.shape[2] > 1 else 0, LG[i], ym)  # fmt: skip
        for j in range(8):
            YM[i, j] = ym[0, j]


@njit
def drive_batch(k, Y, U, P, X, plan, Z, LG, UA):  # noqa: ANN001, ANN201, PLR0913
    """The drive chain for every robot at sample ``k``: commands ``U`` (N, 2) to the torques
    ``UA`` (N, 2) held over the sample; arguments as :func:`sense_batch`."""
    bus = np.zeros(_BUS)
    ua = np.zeros(2)
    for i in range(Y.shape[0]):
        _drive(k, Y[i], U[i, 0], U[i, 1], P[i if P.shape[0] > 1 else 0], X[i], plan, bus, Z, 0,
               i if Z.shape[2] > 1 else 0, 0, LG[i], 0, ua)  # fmt: skip
        UA[i, 0] = ua[0]
        UA[i, 1] = ua[1]


@njit
def _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z,  # noqa: ANN001, ANN202, PLR0913, PLR0912
             SP, SX, splan, DP, DX, dplan, LG0, states, us, logs, u_app, elogs, status,
             t_end, k0, k1, RUN):  # fmt: skip
    if RUN[i, 1] != 0:
        return
    yi = y[i]
    c = coef[i if coef.shape[0] > 1 else 0]
    ti = RUN[i, 2]
    p = P[i if P.shape[0] > 1 else 0]
    x = X[i]
    sp = SP[i if SP.shape[0] > 1 else 0]
    dp = DP[i if DP.shape[0] > 1 else 0]
    sx = SX[i]
    dx = DX[i]
    zi = i if Z.shape[2] > 1 else 0
    ds = splan[splan.shape[0] - 1, 6] if splan.shape[0] > 0 else 0  # the sensor's variates
    ls = LG0.shape[1]  # the sensor's log width: the drive's logs follow
    bus = np.zeros(_BUS)
    ym = np.empty((1, 8))
    u1 = np.zeros((1, 2))
    ua = np.zeros(2)
    lg = np.zeros(logs.shape[2])
    elg = np.zeros(ls + (dplan[dplan.shape[0] - 1, 8] if dplan.shape[0] > 0 else 0))
    keep = elogs.shape[2] > 0
    row = RUN[i, 0]
    n_rec = rec_idx.shape[0]
    for k in range(k0, k1):
        t = k * Ts
        if k == 0:
            for j in range(8):
                ym[0, j] = M0[i, j]
            for j in range(ls):
                elg[j] = LG0[i, j]
        elif splan.shape[0] > 0:
            _sense(k, yi, sp, sx, splan, bus, Z, k - k0, zi, elg, ym)
        else:
            for j in range(8):
                ym[0, j] = yi[j]
        law_step(code, p, x, k, t, ym, u1, lg)
        if dplan.shape[0] > 0:
            _drive(k, yi, u1[0, 0], u1[0, 1], dp, dx, dplan, bus, Z, k - k0, zi, ds, elg, ls,
                   ua)  # fmt: skip
        else:
            ua[0], ua[1] = u1[0, 0], u1[0, 1]
        if row < n_rec and rec_idx[row] == k:
            for j in range(8):
                states[i, row, j] = yi[j]
            us[i, row, 0] = u1[0, 0]
            us[i, row, 1] = u1[0, 1]
            u_app[i, row, 0] = ua[0]
            u_app[i, row, 1] = ua[1]
            if u_app.shape[2] >= 10:  # the measurement the law read, on request
                for j in range(8):
                    u_app[i, row, 2 + j] = ym[0, j]
            for j in range(lg.shape[0]):
                logs[i, row, j] = lg[j]
            if keep:
                for j in range(elg.shape[0]):
                    elogs[i, row, j] = elg[j]
            row += 1
        if k == n_samples or status[i] != OK:  # a stop is recorded at the next sample instant
            RUN[i, 1] = 1
            break
        tk = tau[k - k0 if tau.shape[0] > 1 else 0]
        ur, ul = ua[0], ua[1]
        for s in range(n_sub):
            step_one(yi, ur, ul, tk, s, ti, c, h, method)
            finite = True
            for j in range(8):
                if not math.isfinite(yi[j]):
                    finite = False
            if not finite or abs(yi[1]) >= _FELL_ANGLE:
                status[i] = DIVERGED if not finite else FELL
                t_end[i] = t + (s + 1) * h
                break
    RUN[i, 0] = row


@njit
def run(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z, SP, SX,  # noqa: ANN001, ANN201, PLR0913
        splan, DP, DX, dplan, LG0, states, us, logs, u_app, elogs, status, t_end, k0, k1,
        RUN):  # fmt: skip
    """Samples ``k0 .. k1 - 1`` of every robot's closed loop on the twin, one robot after the
    other (a run is consecutive chunks); returns the robots still running.

    The arguments of :func:`mwip.sim.loop.run`, with ``tau`` the disturbance of samples
    ``k0 ..`` (or one block for all) in columns; ``M0`` (N, 8) the first measurement and
    ``LG0`` (N, w_s) the sensor chain's logs of it; ``Z`` (samples, variates, 1 or N) the
    noise of samples ``k0 ..`` (the sensor chain's variates, then the drive chain's; the
    sensor's at sample 0 are not read: the first measurement is given);
    ``SP``/``DP`` (1 or N, .) the chains' parameters, ``SX``/``DX`` (N, .) their states
    (updated in place), ``splan``/``dplan`` their plans (:mod:`mwip.hardware.pack`); ``RUN``
    (N, 3) int64 per robot: the next record row, 1 once it has left the run (both updated in
    place) and the column of ``tau`` it reads; ``u_app`` (N, R, 2) the applied torques
    recorded, or (N, R, 10): then also the measurement the law read; ``elogs`` (N, R, w) the
    elements' logs (sensor's, then drive's), or (N, R, 0) to record none."""
    running = 0
    for i in range(y.shape[0]):
        _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z,
                 SP, SX, splan, DP, DX, dplan, LG0, states, us, logs, u_app, elogs, status,
                 t_end, k0, k1, RUN)  # fmt: skip
        running += status[i] == OK
    return running


@njit(parallel=True)
def run_parallel(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z,  # noqa: ANN001, ANN201, PLR0913
                 SP, SX, splan, DP, DX, dplan, LG0, states, us, logs, u_app, elogs, status,
                 t_end, k0, k1, RUN):  # fmt: skip
    """:func:`run` with the robots spread over threads: one barrier per call."""
    for i in numba.prange(y.shape[0]):
        _run_one(np.int64(i), y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P,
                 X, M0, Z, SP, SX, splan, DP, DX, dplan, LG0, states, us, logs, u_app, elogs,
                 status, t_end, k0, k1, RUN)  # fmt: skip
    running = 0
    for i in range(y.shape[0]):
        running += status[i] == OK
    return running
