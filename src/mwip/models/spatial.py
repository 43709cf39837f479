"""Three-dimensional MWIP model with nonholonomic constraints, (2.13)-(2.31).

Full configuration ``qf = [x0, y0, alpha, theta, psi_r, psi_l]``. Lagrange's equation with
multipliers (2.23) gives (2.24)::

    M(qf) qf'' + N(qf, qf') = E tau + A(qf)^T mu,     A(qf) qf' = 0   (2.25)-(2.26)

The velocities live in the null space of ``A``: ``qf' = S(qf) z`` with ``z = [th', v, al']``
(2.27)-(2.29), and projecting with ``S^T`` removes the multipliers (2.30)-(2.31)::

    S^T M S z' + S^T (M S' z + N) = S^T E tau.

Differences from the reduced model (2.32), which is the plant (SPEC.md sections 2-3). The
book derives (2.32) "based on (2.31)", but the printed terms of (2.17)-(2.24) differ:

1. (2.20) puts the wheel inertia about a diameter into the *pitch* energy
   (``1/2 Iwd th'^2``, so ``M44 = m1 l1^2 + Iwd + Iyy``), whereas (2.32) puts ``2 Iwd`` into
   the *yaw* inertia ``m33``. Physically the wheels' diametral inertia is turned by yaw,
   not by pitch (the wheels do not pitch with the body), so (2.32) is right.
2. (2.20) keeps the body's own yaw inertia ``Izz cos^2 th``; the printed (2.32) has no such
   term (its yaw inertia is ``(Ibz + mb l^2) sin^2 th + m33``): (2.32) is the body with
   ``Izz = 0``, its ``Ibz`` playing ``Ixx``. mwip's :class:`~mwip.params.Params` carries the
   term as ``Iyaw`` (``Ibl = Ibz - Iyaw + mb l^2``, ``m33`` plus ``Iyaw``; default 0, the
   book's (2.32)), and :meth:`SpatialParams.from_params` maps ``Izz = Iyaw``, so this
   difference is gone for every robot (docs/models.md).
3. (2.22) damps the *absolute* pitch rate (``1/2 Db th'^2``), whereas (2.32) damps the body
   rate *relative to the wheels* (``Db (th' - psi')``, which also adds ``Db`` to the yaw
   damping). The motor and gearbox act between body and wheel, so the relative form of
   (2.32) is the physical one.

With ``Iwd = 0`` and ``Db = 0`` (and ``Ixx = Ibz``, ``Iyy = Iby``, ``Izz = Iyaw``) the two
models coincide exactly after ``v = r psi'``, for any ``Iyaw`` (tested).
:func:`reduced_accelerations` implements the printed (2.24)-(2.31) so that these differences
can be examined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.params import Params, Value

__all__ = [
    "SpatialParams",
    "constraint_matrix",
    "null_space",
    "mass_matrix",
    "bias_forces",
    "input_matrix",
    "reduced_accelerations",
    "planar_velocity",
]


@dataclass(frozen=True)
class SpatialParams:
    """Parameters of the printed spatial model (2.14)-(2.24).

    ``m1, l1`` body mass and centre-of-mass distance; ``Ixx, Iyy, Izz`` the body's principal
    inertias (2.19) about its centre of mass, in body axes: ``Ixx`` about the forward axis
    (roll; (2.20) multiplies it by ``sin^2 th`` in the yaw energy), ``Iyy`` about the axis
    along the axle (pitch), ``Izz`` about the body's long axis, which is vertical when upright
    (yaw; ``cos^2 th`` in (2.20)); wheel ``mw, Iwa, Iwd, rw``; half track ``b``; damping
    ``Db, Dw`` of (2.22).
    """

    m1: Value
    l1: Value
    Ixx: Value
    Iyy: Value
    Izz: Value
    mw: Value
    Iwa: Value
    Iwd: Value
    rw: Value
    b: Value
    Db: Value
    Dw: Value
    g: Value = 9.81

    @classmethod
    def from_params(cls, p: Params, *, Izz: Value | None = None) -> SpatialParams:
        """Map the symbols: ``m1 = mb, l1 = l, Ixx = Ibz`` (roll), ``Iyy = Iby`` (pitch),
        ``Izz = Iyaw`` (yaw; ``Izz`` given overrides it), ``rw = r``."""
        izz = p.Iyaw if Izz is None else Izz
        return cls(
            m1=p.mb, l1=p.l, Ixx=p.Ibz, Iyy=p.Iby, Izz=izz, mw=p.mw, Iwa=p.Iwa, Iwd=p.Iwd,
            rw=p.r, b=p.b, Db=p.Db, Dw=p.Dw, g=p.g,
        )  # fmt: skip


def constraint_matrix(sp: SpatialParams, qf: ArrayLike) -> NDArray[np.float64]:
    """Nonholonomic constraint matrix ``A(qf)`` (2.26), shape (..., 3, 6); ``A qf' = 0``."""
    al = np.asarray(qf, dtype=float)[..., 2]
    s, c = np.sin(al), np.cos(al)
    A = np.zeros((*al.shape, 3, 6))
    A[..., 0, 0], A[..., 0, 1] = -s, c  # no side slip (2.25)
    A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 4] = c, s, sp.b, -sp.rw
    A[..., 2, 0], A[..., 2, 1], A[..., 2, 2], A[..., 2, 5] = c, s, -sp.b, -sp.rw
    return A


def null_space(sp: SpatialParams, qf: ArrayLike) -> NDArray[np.float64]:
    """Null-space basis ``S(qf)`` (2.27), (..., 6, 3): ``qf' = S z``, ``z = [th', v, al']``."""
    al = np.asarray(qf, dtype=float)[..., 2]
    S = np.zeros((*al.shape, 6, 3))
    S[..., 0, 1] = np.cos(al)
    S[..., 1, 1] = np.sin(al)
    S[..., 2, 2] = 1.0
    S[..., 3, 0] = 1.0
    S[..., 4, 1] = S[..., 5, 1] = 1.0 / sp.rw
    S[..., 4, 2] = sp.b / sp.rw
    S[..., 5, 2] = -sp.b / sp.rw
    return S


def _null_space_rate(qf: NDArray[np.float64], ald: NDArray[np.float64]) -> NDArray[np.float64]:
    """``S'(qf) = dS/dalpha * alpha'`` (only the x0, y0 rows depend on alpha)."""
    al = qf[..., 2]
    Sd = np.zeros((*al.shape, 6, 3))
    Sd[..., 0, 1] = -np.sin(al) * ald
    Sd[..., 1, 1] = np.cos(al) * ald
    return Sd


def mass_matrix(sp: SpatialParams, qf: ArrayLike) -> NDArray[np.float64]:
    """Inertia matrix ``M(qf)`` of (2.24), shape (..., 6, 6), as printed."""
    q = np.asarray(qf, dtype=float)
    al, th = q[..., 2], q[..., 3]
    sa, ca, st, ct = np.sin(al), np.cos(al), np.sin(th), np.cos(th)
    m1, l1 = sp.m1, sp.l1
    M = np.zeros((*al.shape, 6, 6))
    M[..., 0, 0] = M[..., 1, 1] = m1
    M[..., 0, 2] = M[..., 2, 0] = -m1 * l1 * st * sa  # M13
    M[..., 0, 3] = M[..., 3, 0] = m1 * l1 * ct * ca  # M14
    M[..., 1, 2] = M[..., 2, 1] = m1 * l1 * st * ca  # M23
    M[..., 1, 3] = M[..., 3, 1] = m1 * l1 * ct * sa  # M24
    M[..., 2, 2] = m1 * (l1 * st) ** 2 + sp.Ixx * st**2 + sp.Izz * ct**2
    M[..., 3, 3] = m1 * l1**2 + sp.Iwd + sp.Iyy  # Iwd here as printed: see module notes
    M[..., 4, 4] = M[..., 5, 5] = sp.mw * sp.rw**2 + sp.Iwa  # M55
    return M


def bias_forces(sp: SpatialParams, qf: ArrayLike, qfd: ArrayLike) -> NDArray[np.float64]:
    """``N(qf, qf')`` of (2.24): velocity products, gravity (2.21) and friction (2.22)."""
    q = np.asarray(qf, dtype=float)
    qd = np.asarray(qfd, dtype=float)
    al, th = q[..., 2], q[..., 3]
    ald, thd = qd[..., 2], qd[..., 3]
    sa, ca, st, ct = np.sin(al), np.cos(al), np.sin(th), np.cos(th)
    m1l = sp.m1 * sp.l1
    k = sp.m1 * sp.l1**2 + sp.Ixx - sp.Izz
    return np.stack(
        np.broadcast_arrays(
            -m1l * st * ca * thd**2 - 2.0 * m1l * ct * sa * ald * thd - m1l * st * ca * ald**2,
            -m1l * st * sa * thd**2 + 2.0 * m1l * ct * ca * ald * thd - m1l * st * sa * ald**2,
            2.0 * k * ct * st * ald * thd,
            -k * ct * st * ald**2 - m1l * sp.g * st + sp.Db * thd,
            sp.Dw * qd[..., 4],
            sp.Dw * qd[..., 5],
        ),
        axis=-1,
    )


def input_matrix() -> NDArray[np.float64]:
    """``E`` of (2.24), shape (6, 2): wheel torques ``[tau_r, tau_l]`` and their reaction."""
    E = np.zeros((6, 2))
    E[3, :] = -1.0
    E[4, 0] = 1.0
    E[5, 1] = 1.0
    return E


def reduced_accelerations(
    sp: SpatialParams, qf: ArrayLike, z: ArrayLike, tau: ArrayLike
) -> NDArray[np.float64]:
    """``z' = [th'', v', al'']`` from the projected dynamics (2.31), shape (..., 3).

    Solves ``S^T M S z' = S^T E tau - S^T (M S' z + N(qf, S z))``.
    """
    q = np.asarray(qf, dtype=float)
    zz = np.asarray(z, dtype=float)
    S = null_space(sp, q)
    M = mass_matrix(sp, q)
    qfd = np.einsum("...ij,...j->...i", S, zz)
    Sd = _null_space_rate(q, zz[..., 2])
    St = np.swapaxes(S, -1, -2)
    H = St @ M @ S
    rhs = np.einsum("...ij,jk,...k->...i", St, input_matrix(), np.asarray(tau, dtype=float))
    rhs = rhs - np.einsum("...ij,...j->...i", St, np.einsum("...ij,...jk,...k->...i", M, Sd, zz))
    rhs = rhs - np.einsum("...ij,...j->...i", St, bias_forces(sp, q, qfd))
    return np.linalg.solve(H, rhs[..., None])[..., 0]


def planar_velocity(alpha: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Planar kinematics (2.28): ``[x', y'] = v [cos alpha, sin alpha]``, shape (..., 2)."""
    a = np.asarray(alpha, dtype=float)
    vv = np.asarray(v, dtype=float)
    return np.stack(np.broadcast_arrays(vv * np.cos(a), vv * np.sin(a)), axis=-1)
