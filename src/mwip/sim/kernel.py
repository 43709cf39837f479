"""Compiled plant integrator: the inner loop of every sampled simulation.

State of one plant (8 numbers): ``y = [psi, theta, alpha, psi', theta', alpha', x, y]``.
Right-hand side: ``q'' `` from the reduced model (2.33) (:mod:`mwip.models.reduced`), and the
planar kinematics ``x' = r psi' cos(alpha)``, ``y' = r psi' sin(alpha)`` (2.28).

Integrator: ROS2, the two-stage linearly implicit Rosenbrock-W method of Verwer, Spee, Blom
and Hundsdorfer (SIAM J. Sci. Comput. 20, 1999)::

    (I - g h W) k1 = f(t_n, y_n)
    (I - g h W) k2 = f(t_n + h, y_n + h k1) - 2 k1
    y_{n+1} = y_n + 3/2 h k1 + 1/2 h k2,        g = 1 + 1/sqrt(2)

It is second order for *any* matrix ``W`` and L-stable when ``W`` is the exact Jacobian. We
take for ``W`` the stiff part only: the damping term ``-M(q_n)^{-1} D q'`` and the trivial
``q' -> q`` coupling. Why (SPEC.md section 2): with the tables' damping the plant has two stable
modes near -3000 rad/s (real parameters) which make explicit RK4 unstable above ~0.9 ms.
With ``W`` containing exactly those modes the stage equations reduce to ``(M + g h D) k = rhs``
(a closed-form 2x2 solve plus a scalar division, :func:`mwip.models.reduced.solve_shifted`),
so a step costs two right-hand sides and no factorisation, and the damping modes are damped
for every step size. The remaining (non-stiff) dynamics, the unstable pitch mode near
+2.4 rad/s among them, are integrated to second order.

One call advances a batch of plants over ``n_sub`` steps with the inputs held (zero-order
hold), checking the events "fell" (``|theta| >= pi/2``) and "diverged" (non-finite state) after
every step; a stopped plant is frozen at the step where its event occurred.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mwip.jit_cache import njit  # the kernels' cache follows every kernel source
from mwip.models.reduced import generalized_forces, solve_shifted
from mwip.sim.codes import DIVERGED, FELL, GAMMA, METHOD_NAMES, OK, RK4, ROS2W, STATUS_NAMES

__all__ = [
    "GAMMA",
    "OK",
    "FELL",
    "DIVERGED",
    "STATUS_NAMES",
    "ROS2W",
    "RK4",
    "METHOD_NAMES",
    "step_one",
    "advance",
    "advance_parallel",
    "rhs_batch",
]

_FELL_ANGLE = 0.5 * math.pi

_gf = njit(inline="always")(generalized_forces)
_solve = njit(inline="always")(solve_shifted)


@njit(inline="always")
def _step(y, ur, ul, e0, e1, c, h):  # noqa: ANN001, ANN202 - compiled kernel
    """One ROS2-W step of one plant, in place on ``y`` (length 8)."""
    m11, m12, m22, m33, Ibl, Gb, Db, Dw, b, r = (
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9]
    )  # fmt: skip
    sig = GAMMA * h
    th, al = y[1], y[2]
    pd, td, ad = y[3], y[4], y[5]
    # stage 1: (M + sig D) k1v = tau - N - O at y_n
    f1, f2, f3 = _gf(m12, Ibl, Gb, Db, Dw, b, r, th, pd, td, ad, ur, ul, e0[0], e0[1], e0[2])
    k1v0, k1v1, k1v2 = _solve(m11, m12, m22, m33, Ibl, Db, Dw, b, r, th, sig, f1, f2, f3)
    k1q0 = pd + sig * k1v0
    k1q1 = td + sig * k1v1
    k1q2 = ad + sig * k1v2
    ca, sa = math.cos(al), math.sin(al)
    k1x = r * pd * ca
    k1y = r * pd * sa
    # stage 2 at y_n + h k1
    th2 = th + h * k1q1
    al2 = al + h * k1q2
    pd2 = pd + h * k1v0
    td2 = td + h * k1v1
    ad2 = ad + h * k1v2
    g1, g2, g3 = _gf(m12, Ibl, Gb, Db, Dw, b, r, th2, pd2, td2, ad2, ur, ul, e1[0], e1[1], e1[2])
    a0, a1, a2 = _solve(m11, m12, m22, m33, Ibl, Db, Dw, b, r, th2, 0.0, g1, g2, g3)
    # right-hand side of the velocity stage, multiplied by M(q_n): M_n (f_v(y2) - 2 k1v)
    d0, d1, d2 = a0 - 2.0 * k1v0, a1 - 2.0 * k1v1, a2 - 2.0 * k1v2
    cth, sth = math.cos(th), math.sin(th)
    r0 = m11 * d0 + m12 * cth * d1
    r1 = m12 * cth * d0 + m22 * d1
    r2 = (m33 + Ibl * sth * sth) * d2
    k2v0, k2v1, k2v2 = _solve(m11, m12, m22, m33, Ibl, Db, Dw, b, r, th, sig, r0, r1, r2)
    k2q0 = pd2 - 2.0 * k1q0 + sig * k2v0
    k2q1 = td2 - 2.0 * k1q1 + sig * k2v1
    k2q2 = ad2 - 2.0 * k1q2 + sig * k2v2
    k2x = r * pd2 * math.cos(al2) - 2.0 * k1x
    k2y = r * pd2 * math.sin(al2) - 2.0 * k1y
    w1, w2 = 1.5 * h, 0.5 * h
    y[0] += w1 * k1q0 + w2 * k2q0
    y[1] += w1 * k1q1 + w2 * k2q1
    y[2] += w1 * k1q2 + w2 * k2q2
    y[3] += w1 * k1v0 + w2 * k2v0
    y[4] += w1 * k1v1 + w2 * k2v1
    y[5] += w1 * k1v2 + w2 * k2v2
    y[6] += w1 * k1x + w2 * k2x
    y[7] += w1 * k1y + w2 * k2y


@njit(inline="always")
def _deriv(c, th, al, pd, td, ad, ur, ul, e):  # noqa: ANN001, ANN202 - compiled kernel
    """Accelerations (2.33) and planar velocities (2.29) of one plant: 5 numbers."""
    f1, f2, f3 = _gf(c[1], c[4], c[5], c[6], c[7], c[8], c[9], th, pd, td, ad, ur, ul,
                     e[0], e[1], e[2])  # fmt: skip
    a0, a1, a2 = _solve(c[0], c[1], c[2], c[3], c[4], c[6], c[7], c[8], c[9], th, 0.0,
                        f1, f2, f3)  # fmt: skip
    return a0, a1, a2, c[9] * pd * math.cos(al), c[9] * pd * math.sin(al)


@njit(inline="always")
def _rk4_step(y, ur, ul, e0, em, e1, c, h):  # noqa: ANN001, ANN202 - compiled kernel
    """One classical RK4 step of one plant, in place on ``y`` (length 8); ``e0, em, e1`` the
    external forces at the start, middle and end of the step."""
    th, al, pd, td, ad = y[1], y[2], y[3], y[4], y[5]
    h2 = 0.5 * h
    a0, a1, a2, x1, y1 = _deriv(c, th, al, pd, td, ad, ur, ul, e0)
    b0, b1, b2, x2, y2 = _deriv(c, th + h2 * td, al + h2 * ad, pd + h2 * a0, td + h2 * a1,
                                ad + h2 * a2, ur, ul, em)  # fmt: skip
    pd2, td2, ad2 = pd + h2 * a0, td + h2 * a1, ad + h2 * a2
    c0, c1, c2, x3, y3 = _deriv(c, th + h2 * td2, al + h2 * ad2, pd + h2 * b0, td + h2 * b1,
                                ad + h2 * b2, ur, ul, em)  # fmt: skip
    pd3, td3, ad3 = pd + h2 * b0, td + h2 * b1, ad + h2 * b2
    d0, d1, d2, x4, y4 = _deriv(c, th + h * td3, al + h * ad3, pd + h * c0, td + h * c1,
                                ad + h * c2, ur, ul, e1)  # fmt: skip
    pd4, td4, ad4 = pd + h * c0, td + h * c1, ad + h * c2
    w = h / 6.0
    y[0] += w * (pd + 2.0 * pd2 + 2.0 * pd3 + pd4)
    y[1] += w * (td + 2.0 * td2 + 2.0 * td3 + td4)
    y[2] += w * (ad + 2.0 * ad2 + 2.0 * ad3 + ad4)
    y[3] += w * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
    y[4] += w * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
    y[5] += w * (a2 + 2.0 * b2 + 2.0 * c2 + d2)
    y[6] += w * (x1 + 2.0 * x2 + 2.0 * x3 + x4)
    y[7] += w * (y1 + 2.0 * y2 + 2.0 * y3 + y4)


@njit(inline="always")
def step_one(yi, ur, ul, tau, k, ti, c, h, method):  # noqa: ANN001, ANN201 - compiled kernel
    """Step ``k`` of a held interval for one plant with ``method`` (:data:`ROS2W` or
    :data:`RK4`); ``tau`` holds the external forces at the step boundaries (ROS2-W, n_sub + 1
    rows) or at the half steps (RK4, 2 n_sub + 1 rows)."""
    if method == RK4:
        _rk4_step(yi, ur, ul, tau[2 * k, ti], tau[2 * k + 1, ti], tau[2 * k + 2, ti], c, h)
    else:
        _step(yi, ur, ul, tau[k, ti], tau[k + 1, ti], c, h)


@njit(inline="always")
def _advance_one(i, y, u, tau, coef, h, n_sub, status, t0, t_end, method):  # noqa: ANN001, ANN202
    if status[i] != OK:
        return
    ti = i if tau.shape[1] > 1 else np.int64(0)
    ci = i if coef.shape[0] > 1 else np.int64(0)
    yi = y[i]
    c = coef[ci]
    ur, ul = u[i, 0], u[i, 1]
    for k in range(n_sub):
        step_one(yi, ur, ul, tau, k, ti, c, h, method)
        finite = True
        for j in range(8):
            if not math.isfinite(yi[j]):
                finite = False
        if not finite:
            status[i] = DIVERGED
            t_end[i] = t0 + (k + 1) * h
            return
        if abs(yi[1]) >= _FELL_ANGLE:
            status[i] = FELL
            t_end[i] = t0 + (k + 1) * h
            return


@njit
def advance(y, u, tau, coef, h, n_sub, status, t0, t_end, method=0):  # noqa: ANN001, ANN201
    """Advance every running plant ``n_sub`` steps of size ``h`` with ``u`` held.

    Parameters (all arrays C-contiguous float64 unless stated)
    ----------------------------------------------------------
    y : (N, 8) state, updated in place
    u : (N, 2) wheel torques ``[u_r, u_l]`` held over the interval
    tau : (n_sub + 1, 1 or N, 3) external generalised forces at the step boundaries
        (RK4: (2 n_sub + 1, 1 or N, 3), at the half steps)
    coef : (1 or N, 10) coefficients, :data:`mwip.models.reduced.COEFF_NAMES`
    status : (N,) int64, 0 ok / 1 fell / 2 diverged; updated in place
    t0 : time at the start of the interval; t_end : (N,) stop times, set on events
    method : :data:`ROS2W` (0, default) or :data:`RK4` (1)

    Returns the number of plants still running.
    """
    running = 0
    for i in range(y.shape[0]):
        _advance_one(i, y, u, tau, coef, h, n_sub, status, t0, t_end, method)
        running += status[i] == OK
    return running


@njit(parallel=True)
def advance_parallel(y, u, tau, coef, h, n_sub, status, t0, t_end, method=0):  # noqa: ANN001, ANN201
    """:func:`advance` with the plants spread over threads (for large batches)."""
    running = 0
    for i in numba.prange(y.shape[0]):
        _advance_one(np.int64(i), y, u, tau, coef, h, n_sub, status, t0, t_end, method)
        running += status[i] == OK
    return running


@njit
def rhs_batch(coef, y, u, e, out):  # noqa: ANN001, ANN201 - compiled kernel
    """Plant right-hand side ``y' = f(y, u, tau_ext)`` for M states at once, into ``out``.

    ``coef`` (M, 10), ``y`` (M, 8) = ``[psi, theta, alpha, psi', theta', alpha', x, y]``,
    ``u`` (M, 2) = ``[u_r, u_l]``, ``e`` (M, 3) external generalised forces. The accelerations
    are (2.33) solved in closed form (:func:`~mwip.models.reduced.solve_shifted` at sigma 0),
    the planar position follows (2.29): ``x' = r psi' cos(alpha)``, ``y' = r psi' sin(alpha)``.
    Used by the continuous mode of :mod:`mwip.sim.engine`.
    """
    for i in range(y.shape[0]):
        c = coef[i]
        m11, m12, m22, m33, Ibl, Gb, Db, Dw, b, r = (
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9]
        )  # fmt: skip
        th, al = y[i, 1], y[i, 2]
        pd, td, ad = y[i, 3], y[i, 4], y[i, 5]
        f1, f2, f3 = _gf(
            m12, Ibl, Gb, Db, Dw, b, r, th, pd, td, ad, u[i, 0], u[i, 1], e[i, 0], e[i, 1], e[i, 2]
        )
        a0, a1, a2 = _solve(m11, m12, m22, m33, Ibl, Db, Dw, b, r, th, 0.0, f1, f2, f3)
        out[i, 0] = pd
        out[i, 1] = td
        out[i, 2] = ad
        out[i, 3] = a0
        out[i, 4] = a1
        out[i, 5] = a2
        out[i, 6] = r * pd * math.cos(al)
        out[i, 7] = r * pd * math.sin(al)
    return out


@njit
def ros2_stage(Winv, f, k_prev, out):  # noqa: ANN001, ANN201 - compiled kernel
    """ROS2-W stage ``k = W^-1 (f - 2 k_prev)`` per plant (``k_prev = 0`` for stage 1)."""
    for i in range(f.shape[0]):
        for a in range(8):
            acc = 0.0
            for b in range(8):
                acc += Winv[i, a, b] * (f[i, b] - 2.0 * k_prev[i, b])
            out[i, a] = acc
    return out


@njit
def ros2_update(y, k1, k2, h, status, t_new, t_end):  # noqa: ANN001, ANN201 - compiled kernel
    """``y += 3/2 h k1 + 1/2 h k2`` for the running plants, then the events: non-finite ->
    diverged, ``|theta| >= pi/2`` -> fell (``t_end = t_new``). Returns the plants running."""
    running = 0
    for i in range(y.shape[0]):
        if status[i] != OK:
            continue
        finite = True
        for a in range(8):
            y[i, a] += 1.5 * h * k1[i, a] + 0.5 * h * k2[i, a]
            if not math.isfinite(y[i, a]):
                finite = False
        if not finite:
            status[i] = DIVERGED
            t_end[i] = t_new
        elif abs(y[i, 1]) >= _FELL_ANGLE:
            status[i] = FELL
            t_end[i] = t_new
        else:
            running += 1
    return running


def advance_batch(
    y: np.ndarray,
    u: np.ndarray,
    tau: np.ndarray,
    coef: np.ndarray,
    h: float,
    n_sub: int,
    status: np.ndarray,
    t0: float,
    t_end: np.ndarray,
    method: int = 0,
) -> int:
    """Dispatch to the serial or threaded kernel by batch size; returns the plants running."""
    fn = advance_parallel if y.shape[0] >= 256 else advance
    return int(fn(y, u, tau, coef, h, n_sub, status, t0, t_end, method))
