"""The twin's closed loop compiled: sensor, packed law, drive and plant of each robot per sample.

The Python loop of :func:`mwip.sim.engine.simulate` with the twin's :class:`TwinSensor` and
:class:`TwinActuator` (:mod:`mwip.hardware.twin`) pays the interpreter and some forty small
NumPy calls per sample (IMU, fusion, encoders, odometry, delay, motor and driver, Coulomb
friction, backlash), then a threaded plant kernel call with its barrier. When the controller
offers its law packed (:class:`mwip.laws.packing.PackedLaw`) and the sensor and drive are the
twin's own, :func:`run` does the same sequence per robot in compiled code, as
:mod:`mwip.sim.loop` does for the plain loop::

    for k = 0 .. n_samples:                  # t_k = k Ts
        y_m = twin sensor(y)                 # k = 0: the engine's own first measurement
        u = law_step(code, p, x, k, t_k, y_m)
        u_a = twin drive(u, y)               # delay, motor + PWM + sag + current limit,
                                             # Coulomb friction, backlash
        record y, u, logs, u_a if k is recorded
        advance the plant Ts/dt steps with u_a held; stop on "fell" / "diverged"

Every line below is the arithmetic of the NumPy code it replaces, operation for operation and
in the same order (the comments name the function), on one robot's scalars; the constants
that NumPy computes once (``exp(-Ts/tau_e)``, ``tau/(tau+Ts)``, ``sqrt(Ts)``, the encoder
resolution) are computed by the same NumPy expressions in :func:`prepare` and passed in. The
IMU's normal variates are drawn before the run from the sensor's own generator, in the order
the Python sensor draws them (per sample: bias walk, accel x, accel y, gyro; one per robot, or
one for all with ``common_noise``), so a seed gives the same noise.

The two paths agree to round-off, not bit for bit: the only operation without a NumPy twin in
compiled code is the accelerometer tilt ``arctan2`` (2.39): NumPy's SIMD ``arctan2`` and the C
library's ``atan2`` that Numba calls differ by one unit in the last place for about 0.1 % of
arguments. The tilt enters the fusion filter (and through it the measurement and the law), not
the torque: the PWM quantisation of the duty absorbs a difference of that size, so the plant
states stay the same (tests/test_twin_loop.py).

The engine finds this loop through :meth:`mwip.hardware.twin.TwinSensor.compiled_loop`, which
packs the sensor and drive (:mod:`mwip.hardware.twin_pack`); this module mirrors the hardware's
arithmetic and imports none of it. ``simulate(..., compiled=False)`` keeps the Python loop.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.laws.dispatch import law_step
from mwip.sim.kernel import DIVERGED, FELL, OK, step_one

__all__ = ["run", "run_parallel", "CHUNK_NUMBERS"]

_FELL_ANGLE = 0.5 * math.pi
_MAXF = float(np.finfo(np.float64).max)

#: Numbers of disturbance and IMU variates tabulated per chunk of samples (the loop runs a long
#: run or a large batch in consecutive chunks of samples).
CHUNK_NUMBERS = 4_000_000

# sensor parameters, one row per robot (or one for all)
(S_TS, S_R, S_BOR, S_GBW, S_ON_N, S_ON_B, S_ON_M, S_ASIG, S_ABIAS, S_GSIG, S_HEIGHT, S_FUSION,
 S_A, S_1MA, S_ENC, S_RES, S_ANY, S_G) = range(18)  # fmt: skip
N_SP = 18
# sensor state: previous true state (8), filter angle, gyro drift, theta_0, previous relative
# wheel angles (2), origin psi, alpha, x, y (4), odometry position (2)
SS_PREV, SS_X0, SS_BIAS, SS_TH0, SS_REL, SS_ORIG, SS_POS = 0, 8, 9, 10, 11, 13, 17
N_SS = 19
# drive parameters
(D_ANY, D_DELAY, D_MOTOR_ANY, D_MOTOR, D_R, D_GAIN, D_GR, D_BOR, D_KE, D_CMODE, D_C, D_VNOM,
 D_LEVELS, D_DEADBAND, D_PWM, D_SAG, D_RS, D_BAND, D_EXP, D_TAU_TS, D_EMF_PLANT, D_FRIC_ANY,
 D_FC, D_MOB, D_TS, D_BL_ANY, D_HALF, D_INERTIA, D_BL_TS) = range(29)  # fmt: skip
N_DP = 29
# drive state: previous command (2), currents (2), battery current, backlash gap (2), rate (2)
DS_UPREV, DS_I, DS_IBAT, DS_G, DS_V = 0, 2, 4, 5, 7
N_DS = 9


@njit(inline="always")
def _sign(x):  # noqa: ANN001, ANN202 - np.sign: 0.0 for either zero, NaN for NaN
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x if x != x else 0.0


@njit(inline="always")
def _maximum(a, b):  # noqa: ANN001, ANN202 - np.maximum (NaN propagates)
    return a if (a >= b or a != a) else b


@njit(inline="always")
def _minimum(a, b):  # noqa: ANN001, ANN202 - np.minimum (NaN propagates)
    return a if (a <= b or a != a) else b


@njit(inline="always")
def _clip(x, lo, hi):  # noqa: ANN001, ANN202 - np.clip = minimum(maximum(x, lo), hi)
    return _minimum(_maximum(x, lo), hi)


@njit(inline="always")
def _nan_to_num(x):  # noqa: ANN001, ANN202
    if x != x:
        return 0.0
    if x == math.inf:
        return _MAXF
    if x == -math.inf:
        return -_MAXF
    return x


@njit(inline="always")
def _sense(yi, sp, ss, c0, Z, kz, zi, ym):  # noqa: ANN001, ANN202, PLR0915 - compiled kernel
    """:meth:`TwinSensor.__call__` after the first call, for one robot: ``ym[0]``."""
    if sp[S_ANY] == 0.0:
        for j in range(8):
            ym[0, j] = yi[j]
        return
    Ts = sp[S_TS]
    acc0 = (yi[3] - ss[SS_PREV + 3]) / Ts
    acc1 = (yi[4] - ss[SS_PREV + 4]) / Ts
    # Imu.read(theta, theta_dot, theta_ddot = acc1, x_ddot = r acc0, dt = Ts)
    walk, nx, ny, ng = Z[kz, 0, zi], Z[kz, 1, zi], Z[kz, 2, zi], Z[kz, 3, zi]
    bias = ss[SS_BIAS] + sp[S_GBW] * walk
    ss[SS_BIAS] = bias
    on_n, on_b, on_m = sp[S_ON_N], sp[S_ON_B], sp[S_ON_M]
    th = yi[1]
    td = on_m * yi[4]
    tdd = on_m * acc1
    xdd = on_m * (sp[S_R] * acc0)
    # specific_force
    height = sp[S_HEIGHT]
    s, c = math.sin(th), math.cos(th)
    fx = xdd + height * (tdd * c - td * td * s)
    fz = sp[S_G] - height * (tdd * s + td * td * c)
    ax = fz * s - fx * c
    ay = fz * c + fx * s
    ax = ax + on_n * sp[S_ASIG] * nx
    ay = ay + on_n * sp[S_ASIG] * ny
    ax = ax + on_b * sp[S_ABIAS]
    omega = yi[4] + on_b * bias + on_n * sp[S_GSIG] * ng
    th_acc = math.atan2(ax, ay)  # tilt_arctan (2.39)
    # TiltFilter.update, complementary_step
    x0 = sp[S_A] * (ss[SS_X0] + omega * Ts) + sp[S_1MA] * th_acc
    ss[SS_X0] = x0
    th_hat, thd_hat = x0, omega
    if sp[S_FUSION] == 0.0:
        th_hat, thd_hat = yi[1], yi[4]
    # encoders: count, counts_to_angle, difference rates, odometry
    bor, res = sp[S_BOR], sp[S_RES]
    rel0 = yi[0] + bor * yi[2] - yi[1]
    rel1 = yi[0] - bor * yi[2] - yi[1]
    rel0 = float(np.int64(math.floor(rel0 / res)) - c0[0]) * res
    rel1 = float(np.int64(math.floor(rel1 / res)) - c0[1]) * res
    rr0 = (rel0 - ss[SS_REL]) / Ts
    rr1 = (rel1 - ss[SS_REL + 1]) / Ts
    ss[SS_REL] = rel0
    ss[SS_REL + 1] = rel1
    psi = ss[SS_ORIG] + (rel0 + rel1) / 2.0 + th_hat - ss[SS_TH0]
    alpha = ss[SS_ORIG + 1] + (rel0 - rel1) / (2.0 * bor)
    psi_dot = (rr0 + rr1) / 2.0 + thd_hat
    alpha_dot = (rr0 - rr1) / (2.0 * bor)
    v = sp[S_R] * psi_dot
    ss[SS_POS] = ss[SS_POS] + Ts * (v * math.cos(alpha))
    ss[SS_POS + 1] = ss[SS_POS + 1] + Ts * (v * math.sin(alpha))
    for j in range(8):
        ss[SS_PREV + j] = yi[j]
    if sp[S_ENC] != 0.0:
        ym[0, 0], ym[0, 2], ym[0, 3], ym[0, 5] = psi, alpha, psi_dot, alpha_dot
        ym[0, 6], ym[0, 7] = ss[SS_POS], ss[SS_POS + 1]
    else:
        ym[0, 0], ym[0, 2], ym[0, 3], ym[0, 5] = yi[0], yi[2], yi[3], yi[5]
        ym[0, 6], ym[0, 7] = yi[6], yi[7]
    ym[0, 1] = th_hat
    ym[0, 4] = thd_hat


@njit(inline="always")
def _motor(yi, u, w, dp, ds):  # noqa: ANN001, ANN202 - compiled kernel
    """:meth:`DriveActuator.__call__` for wheel ``w`` of one robot (torque in, torque out);
    updates the wheel's current (the battery current is summed by the caller)."""
    pd, td, ad = yi[3], yi[4], yi[5]
    bor = dp[D_BOR]
    wheel = pd + bor * ad - td if w == 0 else pd - bor * ad - td
    om = dp[D_GR] * wheel  # motor_speed
    R, gain = dp[D_R], dp[D_GAIN]
    emf = dp[D_KE] * om
    mode = dp[D_CMODE]
    ff = emf if mode == 0.0 else (0.0 if mode == 1.0 else dp[D_C] * emf)
    v_ref = R * _nan_to_num(u) / gain + ff
    duty_ref = v_ref / dp[D_VNOM]
    duty = _clip(duty_ref, -1.0, 1.0)
    if dp[D_PWM] != 0.0:
        shaped = duty
        if dp[D_LEVELS] > 0.0:
            shaped = np.round(shaped * dp[D_LEVELS]) / dp[D_LEVELS]
        duty = _sign(shaped) * _maximum(abs(shaped) - dp[D_DEADBAND], 0.0)  # apply_deadband
    vs = dp[D_VNOM] - (dp[D_RS] * ds[DS_IBAT] if dp[D_SAG] != 0.0 else 0.0)
    vs = _maximum(vs, 0.0)
    v = duty * vs
    band = dp[D_BAND]
    v_lim = _clip(_clip(v, emf - band, emf + band), -vs, vs)
    # current_step
    i_ss = (v_lim - dp[D_KE] * om) / R
    d = ds[DS_I + w] - i_ss
    e = dp[D_EXP]
    ds[DS_I + w] = i_ss + d * e
    i_mean = i_ss + d * dp[D_TAU_TS] * (1.0 - e)
    duty_eff = v_lim / vs if vs > 0 else 0.0
    torque = gain * i_mean
    out = torque + gain * emf / R if dp[D_EMF_PLANT] != 0.0 else torque
    return out, duty_eff * i_mean


@njit(inline="always")
def _backlash(tau, w, dp, ds):  # noqa: ANN001, ANN202 - compiled kernel
    """:meth:`Backlash.__call__` for wheel ``w`` of one robot."""
    Ts, half = dp[D_BL_TS], dp[D_HALF]
    g, v = ds[DS_G + w], ds[DS_V + w]
    s = _sign(tau)
    if s != 0:
        wall = s * half
    else:
        wall = half if v >= 0 else -half
    contact = (half <= 0) or ((s != 0) and (abs(g - wall) <= 1e-15))
    a = tau / dp[D_INERTIA]
    d = wall - g
    disc = v * v + 2.0 * a * d
    quad = abs(a) > 0
    if quad:
        t_c = (-v + _sign(a) * math.sqrt(_maximum(disc, 0.0))) / a if disc >= 0 else math.inf
    else:
        t_c = d / v if v != 0 else math.inf
    if not (math.isfinite(t_c) and t_c >= 0):
        t_c = math.inf
    closes = (not contact) and (t_c <= Ts)
    free = (not contact) and (not closes)
    if contact:
        out = tau
    elif closes:
        out = tau * (Ts - _minimum(t_c, Ts)) / Ts
    else:
        out = 0.0
    if contact or closes:
        ds[DS_G + w] = wall
        ds[DS_V + w] = 0.0
    elif free:
        ds[DS_G + w] = _clip(g + v * Ts + 0.5 * a * Ts * Ts, -half, half)
        ds[DS_V + w] = v + a * Ts
    return out


@njit(inline="always")
def _drive(yi, u0, u1, dp, ds, ua):  # noqa: ANN001, ANN202 - compiled kernel
    """:meth:`TwinActuator.__call__` for one robot: the torques held over the sample."""
    if dp[D_ANY] == 0.0:
        ua[0], ua[1] = u0, u1
        return
    d = dp[D_DELAY]
    a0 = d * ds[DS_UPREV] + (1.0 - d) * u0
    a1 = d * ds[DS_UPREV + 1] + (1.0 - d) * u1
    ds[DS_UPREV], ds[DS_UPREV + 1] = u0, u1
    if dp[D_MOTOR_ANY] != 0.0:
        m0, p0 = _motor(yi, a0, 0, dp, ds)
        m1, p1 = _motor(yi, a1, 1, dp, ds)
        ds[DS_IBAT] = p0 + p1
        if dp[D_MOTOR] != 0.0:
            a0, a1 = m0, m1
    if dp[D_FRIC_ANY] != 0.0:  # coulomb_torque
        bor, gr = dp[D_BOR], dp[D_GR]
        pd, td, ad = yi[3], yi[4], yi[5]
        fc, m, Ts = dp[D_FC], dp[D_MOB], dp[D_TS]
        for w in range(2):
            wheel = pd + bor * ad - td if w == 0 else pd - bor * ad - td
            om = gr * wheel / gr
            drv = a0 if w == 0 else a1
            need = -om / (Ts * m) - drv
            fric = need if abs(need) <= fc else -fc * _sign(om + Ts * m * drv)
            if w == 0:
                a0 = a0 + fric
            else:
                a1 = a1 + fric
    if dp[D_BL_ANY] != 0.0:
        a0 = _backlash(a0, 0, dp, ds)
        a1 = _backlash(a1, 1, dp, ds)
    ua[0], ua[1] = a0, a1


@njit(inline="always")
def _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z,  # noqa: ANN001, ANN202, PLR0913
             SP, SS, C0, DP, DS, states, us, logs, u_app, status, t_end, k0, k1,
             RUN):  # fmt: skip
    if RUN[i, 1] != 0:
        return
    yi = y[i]
    c = coef[i if coef.shape[0] > 1 else 0]
    ti = RUN[i, 2]
    p = P[i if P.shape[0] > 1 else 0]
    x = X[i]
    sp = SP[i if SP.shape[0] > 1 else 0]
    dp = DP[i if DP.shape[0] > 1 else 0]
    ss = SS[i]
    ds = DS[i]
    c0 = C0[i]
    zi = i if Z.shape[2] > 1 else 0
    z0 = max(k0, 1)
    ym = np.empty((1, 8))
    u1 = np.zeros((1, 2))
    ua = np.zeros(2)
    lg = np.zeros(logs.shape[2])
    row = RUN[i, 0]
    n_rec = rec_idx.shape[0]
    for k in range(k0, k1):
        t = k * Ts
        if k == 0:
            for j in range(8):
                ym[0, j] = M0[i, j]
        else:
            _sense(yi, sp, ss, c0, Z, k - z0, zi, ym)
        law_step(code, p, x, k, t, ym, u1, lg)
        _drive(yi, u1[0, 0], u1[0, 1], dp, ds, ua)
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
def run(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z, SP, SS, C0,  # noqa: ANN001, ANN201, PLR0913
        DP, DS, states, us, logs, u_app, status, t_end, k0, k1, RUN):  # fmt: skip
    """Samples ``k0 .. k1 - 1`` of every robot's closed loop on the twin, one robot after the
    other (a run is one call with ``k0 = 0, k1 = n_samples + 1``, or consecutive chunks);
    returns the robots still running. The arguments of :func:`mwip.sim.loop.run` with ``tau``
    the disturbance of samples ``k0 ..`` (or one block for all) in columns, and ``M0`` (N, 8)
    the first measurement, ``Z`` (samples, 4, 1 or N) the IMU variates of samples
    ``max(k0, 1) ..``, ``SP`` / ``DP`` (1 or N, ...) the sensor's and drive's parameters,
    ``SS`` / ``C0`` / ``DS`` (N, ...) their states, ``RUN`` (N, 3) int64 per robot: the next
    record row, 1 once it has left the run (both updated in place) and the column of ``tau``
    it reads; ``u_app`` (N, R, 2) the applied torques recorded, or (N, R, 10): then also
    the measurement ``y_m`` the law read at each recorded sample (columns 2-9). A robot that
    stops is recorded at the next sample instant and then left."""
    running = 0
    for i in range(y.shape[0]):
        _run_one(i, y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z,
                 SP, SS, C0, DP, DS, states, us, logs, u_app, status, t_end, k0, k1,
                 RUN)  # fmt: skip
        running += status[i] == OK
    return running


@njit(parallel=True)
def run_parallel(y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P, X, M0, Z, SP,  # noqa: ANN001, ANN201, PLR0913
                 SS, C0, DP, DS, states, us, logs, u_app, status, t_end, k0, k1,
                 RUN):  # fmt: skip
    """:func:`run` with the robots spread over threads: one barrier per call."""
    for i in numba.prange(y.shape[0]):
        _run_one(np.int64(i), y, coef, tau, method, h, n_sub, n_samples, Ts, rec_idx, code, P,
                 X, M0, Z, SP, SS, C0, DP, DS, states, us, logs, u_app, status, t_end, k0, k1,
                 RUN)  # fmt: skip
    running = 0
    for i in range(y.shape[0]):
        running += status[i] == OK
    return running
