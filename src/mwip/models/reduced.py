"""Reduced MWIP model with lumped uncertainties, (2.32)-(2.36). This is the plant.

Generalised coordinates ``q = [psi, theta, alpha]`` (mean wheel angle, body pitch, yaw),
inputs ``u = [u_r, u_l]`` (wheel torques, N m). The model (2.33) reads

.. math::

    M(q)\\ddot q + N(q, \\dot q) + O(\\dot q) = \\tau(u) + \\tau_{ext}

with (2.32)

- ``M = [[m11, m12 cos th, 0], [m12 cos th, m22, 0], [0, 0, Ibl sin^2 th + m33]]``
- ``N = [-m12 sin th (th'^2 + al'^2),
         -Ibl sin th cos th al'^2 - Gb sin th,
         2 Ibl sin th cos th th' al' + m12 sin th psi' al']``
- ``O = D q'`` with the constant damping matrix
  ``D = [[2Dw + 2Db, -2Db, 0], [-2Db, 2Db, 0], [0, 0, 2 b^2/r^2 (Db + Dw)]]``
- ``tau = [u_r + u_l, -(u_r + u_l), (b/r)(u_r - u_l)]``.

``Ibl`` and ``m33`` are :class:`~mwip.params.Params`' coefficients of (2.32) with the body's own
yaw inertia ``Iyaw`` folded in (``Ibl = Ibz - Iyaw + mb l^2``, ``m33`` plus ``Iyaw``): the
general rigid body keeps (2.32)'s form exactly, and ``Iyaw = 0`` (the default) is the book's
(2.32) as printed (docs/models.md, "The body's inertias").

Solving for the accelerations gives (2.36): ``q'' = F + G [u_A, u_B] + tau_d`` with
``u_A = u_r + u_l``, ``u_B = u_r - u_l``.

All functions are batch-first: leading axes of ``q, qdot, u`` and of array-valued
:class:`~mwip.params.Params` fields broadcast.

The scalar kernels :func:`generalized_forces` and :func:`solve_shifted` are written so the
same source runs vectorised under NumPy and compiled (scalar) under Numba inside the
simulation engine (:mod:`mwip.sim.kernel`); there is one implementation of the equations.

Energy (SPEC.md section 3): with ``D = 0`` and ``u = tau_ext = 0``,
``E = T + Gb cos th`` with ``T = 1/2 q'^T M q'`` is conserved; the ``al'^2`` term of the first
row and the ``psi' al'`` term of the third exchange no power (see :func:`energy`).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.params import Params

__all__ = [
    "generalized_forces",
    "solve_shifted",
    "mass_matrix",
    "bias_forces",
    "damping_matrix",
    "damping_forces",
    "input_forces",
    "accelerations",
    "f_g",
    "f_g_terms",
    "lumped_disturbance",
    "energy",
    "input_power",
    "dissipated_power",
    "coefficients",
    "COEFF_NAMES",
]

#: Order of the per-robot coefficient vector used by the compiled engine.
COEFF_NAMES: tuple[str, ...] = ("m11", "m12", "m22", "m33", "Ibl", "Gb", "Db", "Dw", "b", "r")


def coefficients(p: Params) -> NDArray[np.float64]:
    """Coefficient vector ``[m11, m12, m22, m33, Ibl, Gb, Db, Dw, b, r]``, shape (..., 10)."""
    shape = p.batch_shape
    return np.stack(
        [np.broadcast_to(np.asarray(getattr(p, n), dtype=float), shape) for n in COEFF_NAMES],
        axis=-1,
    )


@functools.lru_cache(maxsize=64)
def _scalar_coefficients(p: Params) -> NDArray[np.float64]:
    """:func:`coefficients` of one robot (hashable frozen ``Params``), cached: read-only."""
    c = coefficients(p)
    c.flags.writeable = False
    return c


# ---------------------------------------------------------------------------------------------
# Scalar kernels (NumPy- and Numba-compatible). Keep them free of Python objects.
# ---------------------------------------------------------------------------------------------
def generalized_forces(
    m12: Any, Ibl: Any, Gb: Any, Db: Any, Dw: Any, b: Any, r: Any,
    th: Any, psid: Any, thd: Any, ald: Any,
    ur: Any, ul: Any, e1: Any, e2: Any, e3: Any,
) -> tuple[Any, Any, Any]:  # fmt: skip
    """Right-hand side ``tau + tau_ext - N - O`` of (2.33), component-wise; see (2.32).

    Returns the three generalised forces on ``psi, theta, alpha`` (N m).
    """
    s = np.sin(th)
    c = np.cos(th)
    uA = ur + ul
    rel = thd - psid  # body rate relative to the wheels: the motor/gearbox damping acts on it
    q1 = m12 * s * (thd * thd + ald * ald) - 2.0 * Dw * psid + 2.0 * Db * rel + uA + e1
    q2 = Ibl * s * c * ald * ald + Gb * s - 2.0 * Db * rel - uA + e2
    q3 = (
        -2.0 * Ibl * s * c * ald * thd
        - m12 * s * ald * psid
        - 2.0 * b * b / (r * r) * (Db + Dw) * ald
        + b / r * (ur - ul)
        + e3
    )
    return q1, q2, q3


def solve_shifted(
    m11: Any, m12: Any, m22: Any, m33: Any, Ibl: Any, Db: Any, Dw: Any, b: Any, r: Any,
    th: Any, sigma: Any, q1: Any, q2: Any, q3: Any,
) -> tuple[Any, Any, Any]:  # fmt: skip
    """Solve ``(M(q) + sigma D) a = [q1, q2, q3]`` in closed form.

    ``sigma = 0`` gives the accelerations of (2.33). ``sigma = gamma h`` is the stage matrix
    of the linearly implicit integrator (:mod:`mwip.sim.kernel`), which treats the stiff
    damping term ``D q'`` implicitly. The ``(psi, theta)`` block is 2x2, yaw decouples.
    """
    c = np.cos(th)
    s = np.sin(th)
    a11 = m11 + sigma * 2.0 * (Dw + Db)
    a12 = m12 * c - sigma * 2.0 * Db
    a22 = m22 + sigma * 2.0 * Db
    det = a11 * a22 - a12 * a12
    acc1 = (a22 * q1 - a12 * q2) / det
    acc2 = (a11 * q2 - a12 * q1) / det
    acc3 = q3 / (m33 + Ibl * s * s + sigma * 2.0 * b * b / (r * r) * (Db + Dw))
    return acc1, acc2, acc3


# ---------------------------------------------------------------------------------------------
# Public, batch-first API
# ---------------------------------------------------------------------------------------------
def _split(x: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] != (n,):
        raise ValueError(f"{name} must have shape (..., {n}), got {a.shape}")
    return a


def mass_matrix(p: Params, q: ArrayLike) -> NDArray[np.float64]:
    """Inertia matrix ``M(q)`` of (2.33), shape (..., 3, 3)."""
    th = _split(q, 3, "q")[..., 1]
    c = np.cos(th)
    shape = np.broadcast_shapes(th.shape, p.batch_shape)
    M = np.zeros((*shape, 3, 3))
    M[..., 0, 0] = p.m11
    M[..., 0, 1] = M[..., 1, 0] = p.m12 * c
    M[..., 1, 1] = p.m22
    M[..., 2, 2] = p.Ibl * np.sin(th) ** 2 + p.m33
    return M


def bias_forces(p: Params, q: ArrayLike, qdot: ArrayLike) -> NDArray[np.float64]:
    """Coriolis, centrifugal and gravity vector ``N(q, q')`` of (2.33), shape (..., 3)."""
    th = _split(q, 3, "q")[..., 1]
    qd = _split(qdot, 3, "qdot")
    psid, thd, ald = qd[..., 0], qd[..., 1], qd[..., 2]
    s, c = np.sin(th), np.cos(th)
    return np.stack(
        np.broadcast_arrays(
            -p.m12 * s * (thd**2 + ald**2),
            -p.Ibl * s * c * ald**2 - p.Gb * s,
            2.0 * p.Ibl * s * c * thd * ald + p.m12 * s * psid * ald,
        ),
        axis=-1,
    )


def damping_matrix(p: Params) -> NDArray[np.float64]:
    """Constant damping matrix ``D`` with ``O(q') = D q'`` of (2.33), shape (..., 3, 3)."""
    D = np.zeros((*p.batch_shape, 3, 3))
    D[..., 0, 0] = 2.0 * (p.Dw + p.Db)
    D[..., 0, 1] = D[..., 1, 0] = -2.0 * p.Db
    D[..., 1, 1] = 2.0 * p.Db
    D[..., 2, 2] = 2.0 * p.b**2 / p.r**2 * (p.Db + p.Dw)
    return D


def damping_forces(p: Params, qdot: ArrayLike) -> NDArray[np.float64]:
    """Friction vector ``O(q')`` of (2.33), shape (..., 3)."""
    qd = _split(qdot, 3, "qdot")
    return np.einsum("...ij,...j->...i", damping_matrix(p), qd)


def input_forces(p: Params, u: ArrayLike) -> NDArray[np.float64]:
    """Generalised input forces ``tau = [u_r+u_l, -(u_r+u_l), (b/r)(u_r-u_l)]`` (2.33)."""
    uu = _split(u, 2, "u")
    ur, ul = uu[..., 0], uu[..., 1]
    return np.stack(np.broadcast_arrays(ur + ul, -(ur + ul), p.b / p.r * (ur - ul)), axis=-1)


def accelerations(
    p: Params,
    q: ArrayLike,
    qdot: ArrayLike,
    u: ArrayLike,
    tau_ext: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Accelerations ``q''`` of the reduced model (2.32)/(2.33), shape (..., 3).

    Parameters
    ----------
    p : Params
        Robot parameters (the plant uses :data:`mwip.params.REAL`).
    q, qdot : array (..., 3)
        ``[psi, theta, alpha]`` and their rates.
    u : array (..., 2)
        Wheel torques ``[u_r, u_l]`` (N m).
    tau_ext : array (..., 3), optional
        External generalised forces added to the right-hand side of (2.33).
    """
    qq = _split(q, 3, "q")
    qd = _split(qdot, 3, "qdot")
    uu = _split(u, 2, "u")
    e = np.zeros(3) if tau_ext is None else _split(tau_ext, 3, "tau_ext")
    th = qq[..., 1]
    f1, f2, f3 = generalized_forces(
        p.m12, p.Ibl, p.Gb, p.Db, p.Dw, p.b, p.r,
        th, qd[..., 0], qd[..., 1], qd[..., 2],
        uu[..., 0], uu[..., 1], e[..., 0], e[..., 1], e[..., 2],
    )  # fmt: skip
    a1, a2, a3 = solve_shifted(
        p.m11, p.m12, p.m22, p.m33, p.Ibl, p.Db, p.Dw, p.b, p.r, th, 0.0, f1, f2, f3
    )
    return np.stack(np.broadcast_arrays(a1, a2, a3), axis=-1)


def f_g(
    p: Params, q: ArrayLike, qdot: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Drift ``F`` (..., 3) and input matrix ``G`` (..., 3, 2) of (2.36).

    ``q'' = F + G [u_A, u_B] + tau_d`` with ``u_A = u_r + u_l``, ``u_B = u_r - u_l``. The
    closed forms are the book's (2.36), with ``Delta_1 = m11 m22 - m12^2 cos^2 th`` and
    ``Delta_2 = m33 + Ibl sin^2 th``::

        f1 = [m12 m22 s (th'^2 + al'^2) - m12 Ibl s c^2 al'^2 - m12 Gb s c
              + 2 (m22 + m12 c) Db (th' - psi') - 2 m22 Dw psi'] / Delta_1
        g1 = (m22 + m12 c) / Delta_1
        f2 = [m11 Ibl s c al'^2 + m11 Gb s - m12^2 s c (th'^2 + al'^2)
              - 2 (m11 + m12 c) Db (th' - psi') + 2 m12 c Dw psi'] / Delta_1
        g2 = -(m11 + m12 c) / Delta_1
        f3 = [-2 Ibl s c th' al' - m12 s psi' al' - (2 b^2/r^2)(Db + Dw) al'] / Delta_2
        g3 = (b / r) / Delta_2

    They agree with solving the mass matrix of (2.33) (tested). Controllers and observers
    call this with the *nominal* parameters.
    """
    qq = _split(q, 3, "q")
    qd = _split(qdot, 3, "qdot")
    if qq.ndim == 2 and qd.shape == qq.shape and not p.batch_shape:
        # the hot path of every model-based controller: one compiled loop over the batch
        from mwip.models._compiled import f_g_batch

        F = np.empty(qq.shape)
        G = np.zeros((qq.shape[0], 3, 2))
        f_g_batch(_scalar_coefficients(p), np.ascontiguousarray(qq), np.ascontiguousarray(qd), F, G)
        return F, G
    f1, f2, f3, g1, g2, g3 = f_g_terms(
        p.m11, p.m12, p.m22, p.m33, p.Ibl, p.Gb, p.Db, p.Dw, p.b, p.r,
        qq[..., 1], qd[..., 0], qd[..., 1], qd[..., 2],
    )  # fmt: skip
    F = np.stack(np.broadcast_arrays(f1, f2, f3), axis=-1)
    g1, g2, g3 = np.broadcast_arrays(g1, g2, g3)
    G = np.zeros((*g1.shape, 3, 2))
    G[..., 0, 0] = g1
    G[..., 1, 0] = g2
    G[..., 2, 1] = g3
    return F, G


def f_g_terms(
    m11: Any, m12: Any, m22: Any, m33: Any, Ibl: Any, Gb: Any, Db: Any, Dw: Any, b: Any, r: Any,
    th: Any, psid: Any, thd: Any, ald: Any,
) -> tuple[Any, Any, Any, Any, Any, Any]:  # fmt: skip
    """The closed forms ``f1, f2, f3, g1, g2, g3`` of (2.36) (see :func:`f_g`).

    Scalar kernel: NumPy-vectorised on arrays and compiled by Numba for the batch loop of
    :func:`f_g`, so the equations exist once.
    """
    s = np.sin(th)
    c = np.cos(th)
    d1 = m11 * m22 - m12 * m12 * c * c  # Delta_1 > 0
    d2 = m33 + Ibl * s * s  # Delta_2
    rel = thd - psid
    v2 = thd * thd + ald * ald
    f1 = (
        m12 * m22 * s * v2
        - m12 * Ibl * s * c * c * ald * ald
        - m12 * Gb * s * c
        + 2.0 * (m22 + m12 * c) * Db * rel
        - 2.0 * m22 * Dw * psid
    ) / d1
    f2 = (
        m11 * Ibl * s * c * ald * ald
        + m11 * Gb * s
        - m12 * m12 * s * c * v2
        - 2.0 * (m11 + m12 * c) * Db * rel
        + 2.0 * m12 * c * Dw * psid
    ) / d1
    f3 = (-2.0 * Ibl * s * c * thd * ald - m12 * s * psid * ald
          - 2.0 * b * b / (r * r) * (Db + Dw) * ald) / d2  # fmt: skip
    g1 = (m22 + m12 * c) / d1
    g2 = -(m11 + m12 * c) / d1
    g3 = b / r / d2
    return f1, f2, f3, g1, g2, g3


def lumped_disturbance(
    p_nominal: Params,
    q: ArrayLike,
    qdot: ArrayLike,
    qddot: ArrayLike,
    u: ArrayLike,
) -> NDArray[np.float64]:
    """The lumped disturbance ``tau_d = q'' - F - G [u_A, u_B]`` of (2.36), shape (..., 3).

    Evaluated on the *true* accelerations of the plant with the *nominal* ``F, G``, it is the
    quantity the disturbance observers estimate: external disturbance plus model mismatch,
    in acceleration coordinates (SPEC.md section 2).
    """
    uu = _split(u, 2, "u")
    uAB = np.stack([uu[..., 0] + uu[..., 1], uu[..., 0] - uu[..., 1]], axis=-1)
    F, G = f_g(p_nominal, q, qdot)
    return np.asarray(qddot, dtype=float) - F - np.einsum("...ij,...j->...i", G, uAB)


def energy(p: Params, q: ArrayLike, qdot: ArrayLike) -> NDArray[np.float64]:
    """Mechanical energy ``T + Gb cos th`` with ``T = 1/2 q'^T M(q) q'`` (SPEC.md section 3)."""
    qd = _split(qdot, 3, "qdot")
    M = mass_matrix(p, q)
    T = 0.5 * np.einsum("...i,...ij,...j->...", qd, M, qd)
    return T + p.Gb * np.cos(np.asarray(q, dtype=float)[..., 1])


def input_power(p: Params, qdot: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
    """Power delivered by the wheel torques, ``q'^T tau(u)`` (W)."""
    return np.einsum("...i,...i->...", _split(qdot, 3, "qdot"), input_forces(p, u))


def dissipated_power(p: Params, qdot: ArrayLike) -> NDArray[np.float64]:
    """Power lost to friction, ``q'^T D q' >= 0`` (W)."""
    qd = _split(qdot, 3, "qdot")
    return np.einsum("...i,...i->...", qd, damping_forces(p, qd))
