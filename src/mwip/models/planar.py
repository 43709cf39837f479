"""Two-dimensional MWIP on a slope, (2.1)-(2.12).

Coordinates ``q2 = [theta_w, theta_b]`` (wheel rotation, body angle from the vertical); the
slope angle ``a`` (the book's alpha in Fig. 2.1, *not* the yaw) is a parameter. (2.12)::

    M(q2) q2'' + N(q2, q2') = E tau,   E = [1, -1]^T

    M = [[(mb + mw) r^2 + Iw,       mb l r cos(th_b + a)],
         [mb l r cos(th_b + a),     mb l^2 + Ib         ]]
    N = [Dw th_w' - Db (th_b' - th_w') - mb l r th_b'^2 sin(th_b + a) + (mb + mw) r g sin a,
         Db (th_b' - th_w') - mb g l sin th_b]

Here ``mw, Iw`` are the mass and axle inertia of the whole wheel set and ``tau`` the total
wheel torque. :meth:`PlanarParams.from_params` lumps the two wheels of a :class:`Params`
(``mw -> 2 mw``, ``Iw -> 2 Iwa``, ``Db -> 2 Db``, ``Dw -> 2 Dw``); at zero slope the model
then equals the ``(psi, theta)`` rows of the reduced model (2.32) without yaw (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.params import Params, Value

__all__ = ["PlanarParams", "mass_matrix", "bias_forces", "accelerations", "energy"]


@dataclass(frozen=True)
class PlanarParams:
    """Parameters of the planar model (2.12): body ``mb, Ib, l``, wheel set ``mw, Iw, r``."""

    mb: Value
    mw: Value
    Ib: Value
    Iw: Value
    l: Value
    r: Value
    Db: Value
    Dw: Value
    g: Value = 9.81

    @classmethod
    def from_params(cls, p: Params) -> PlanarParams:
        """Lump both wheels of ``p`` into one wheel set (see module docstring)."""
        return cls(
            mb=p.mb, mw=2.0 * p.mw, Ib=p.Iby, Iw=2.0 * p.Iwa, l=p.l, r=p.r,
            Db=2.0 * p.Db, Dw=2.0 * p.Dw, g=p.g,
        )  # fmt: skip


def mass_matrix(pp: PlanarParams, q2: ArrayLike, slope: float = 0.0) -> NDArray[np.float64]:
    """``M(q2)`` of (2.12), shape (..., 2, 2)."""
    thb = np.asarray(q2, dtype=float)[..., 1]
    c = pp.mb * pp.l * pp.r * np.cos(thb + slope)
    M = np.zeros((*thb.shape, 2, 2))
    M[..., 0, 0] = (pp.mb + pp.mw) * pp.r**2 + pp.Iw
    M[..., 0, 1] = M[..., 1, 0] = c
    M[..., 1, 1] = pp.mb * pp.l**2 + pp.Ib
    return M


def bias_forces(
    pp: PlanarParams, q2: ArrayLike, q2d: ArrayLike, slope: float = 0.0
) -> NDArray[np.float64]:
    """``N(q2, q2')`` of (2.12), shape (..., 2): friction, centrifugal and gravity terms."""
    thb = np.asarray(q2, dtype=float)[..., 1]
    qd = np.asarray(q2d, dtype=float)
    thwd, thbd = qd[..., 0], qd[..., 1]
    rel = thbd - thwd
    n1 = (
        pp.Dw * thwd
        - pp.Db * rel
        - pp.mb * pp.l * pp.r * thbd**2 * np.sin(thb + slope)
        + (pp.mb + pp.mw) * pp.r * pp.g * np.sin(slope)
    )
    n2 = pp.Db * rel - pp.mb * pp.g * pp.l * np.sin(thb)
    return np.stack(np.broadcast_arrays(n1, n2), axis=-1)


def accelerations(
    pp: PlanarParams, q2: ArrayLike, q2d: ArrayLike, tau: ArrayLike, slope: float = 0.0
) -> NDArray[np.float64]:
    """``q2''`` from (2.12) for total wheel torque ``tau`` (...,), shape (..., 2)."""
    t = np.asarray(tau, dtype=float)
    rhs = np.stack(np.broadcast_arrays(t, -t), axis=-1) - bias_forces(pp, q2, q2d, slope)
    return np.asarray(np.linalg.solve(mass_matrix(pp, q2, slope), rhs[..., None])[..., 0], float)


def energy(
    pp: PlanarParams, q2: ArrayLike, q2d: ArrayLike, slope: float = 0.0
) -> NDArray[np.float64]:
    """Total energy ``Vb + Vw + Ub + Uw`` of (2.5)-(2.8)."""
    q = np.asarray(q2, dtype=float)
    qd = np.asarray(q2d, dtype=float)
    T = 0.5 * np.einsum("...i,...ij,...j->...", qd, mass_matrix(pp, q, slope), qd)
    U = pp.mb * pp.g * pp.l * np.cos(q[..., 1]) + (pp.mb + pp.mw) * pp.g * pp.r * q[
        ..., 0
    ] * np.sin(slope)
    return T + U
