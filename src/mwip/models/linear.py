"""Linearisation of the reduced model about the upright equilibrium (Section 4.4).

State ``x = [theta, alpha, theta', v, alpha']`` with ``v = r psi'``, input ``u = [u_r, u_l]``.
About ``x = 0, u = 0`` the model (2.32) gives, with ``M0 = [[m11, m12], [m12, m22]]`` and the
``(psi, theta)`` block ``D2 = [[2(Dw + Db), -2 Db], [-2 Db, 2 Db]]`` of the damping matrix::

    M0 [psi'', theta'']^T = [0, Gb theta]^T - D2 [v / r, theta']^T + [1, -1]^T (u_r + u_l)
    m33 alpha'' = -(2 b^2 / r^2)(Db + Dw) alpha' + (b / r)(u_r - u_l)

and ``v' = r psi''``. The pitch/wheel and yaw subsystems decouple at the equilibrium.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.params import Params

__all__ = ["linearize", "statespace", "STATE_NAMES", "INPUT_NAMES", "state_from_q"]

STATE_NAMES: tuple[str, ...] = ("theta", "alpha", "theta_dot", "v", "alpha_dot")
INPUT_NAMES: tuple[str, ...] = ("u_r", "u_l")


def linearize(p: Params, *, as_statespace: bool = False, Ts: float | None = None) -> Any:
    """Analytic Jacobians ``(A, B)`` at upright, shapes (..., 5, 5) and (..., 5, 2).

    Batched parameters give a leading batch axis. Checked against finite differences of
    :func:`mwip.models.reduced.accelerations` in the tests.

    ``as_statespace=True`` returns a python-control ``StateSpace`` instead (optional
    dependency, ``pip install mwip[control]``; one robot only) with the full state as output
    (``C = I``, ``D = 0``) and named signals; with ``Ts`` the zero-order-hold model sampled at
    ``Ts`` (the model :func:`mwip.laws.lqr.controller.dlqr` designs on).
    """
    if as_statespace:
        return statespace(p, Ts=Ts)
    if Ts is not None:
        raise ValueError("Ts is only used with as_statespace=True (see mwip.laws.lqr.zoh)")
    if not isinstance(p, Params):
        raise TypeError(f"p must be a mwip.params.Params, got {type(p).__name__}")
    shape = p.batch_shape
    one = np.ones(shape)
    m11, m12, m22, m33 = p.m11 * one, p.m12 * one, p.m22 * one, p.m33 * one
    det = m11 * m22 - m12**2
    # rows of M0^{-1}: inv = [[m22, -m12], [-m12, m11]] / det
    i00, i01, i11 = m22 / det, -m12 / det, m11 / det
    d00, d01, d11 = 2.0 * (p.Dw + p.Db) * one, -2.0 * p.Db * one, 2.0 * p.Db * one
    Gb, r, b = p.Gb * one, p.r * one, p.b * one

    A = np.zeros((*shape, 5, 5))
    B = np.zeros((*shape, 5, 2))
    A[..., 0, 2] = 1.0
    A[..., 1, 4] = 1.0
    # theta'' row (index 1 of M0^{-1} rhs) and psi'' row (index 0), rhs columns:
    #   d/dtheta: [0, Gb]; d/dtheta': -D2[:, 1]; d/dv: -D2[:, 0] / r; d/duA: [1, -1]
    for row, (ia, ib), scale in ((2, (i01, i11), 1.0), (3, (i00, i01), r)):
        A[..., row, 0] = scale * (ib * Gb)
        A[..., row, 2] = -scale * (ia * d01 + ib * d11)
        A[..., row, 3] = -scale * (ia * d00 + ib * d01) / r
        B[..., row, 0] = B[..., row, 1] = scale * (ia - ib)
    A[..., 4, 4] = -2.0 * b**2 / r**2 * (p.Db + p.Dw) / m33
    B[..., 4, 0] = b / (r * m33)
    B[..., 4, 1] = -b / (r * m33)
    return A, B


def statespace(p: Params, *, Ts: float | None = None) -> Any:
    """``control.StateSpace`` of the linearisation at upright (continuous, or ZOH at ``Ts``).

    python-control is an optional dependency (``pip install mwip[control]``), imported here
    when called. Re-exported by :mod:`mwip.pycontrol`.

    >>> from mwip.params import NOMINAL
    >>> statespace(NOMINAL, Ts=0.005).dt
    0.005
    """
    try:
        import control as ct
    except ImportError as exc:
        raise ImportError(
            "python-control is needed for this: pip install 'mwip[control]' (or control)"
        ) from exc
    if not isinstance(p, Params):
        raise TypeError(f"p must be a mwip.params.Params, got {type(p).__name__}")
    if p.batch_shape != ():
        raise ValueError("python-control systems describe one robot: pass scalar Params")
    A, B = linearize(p)
    sys = ct.ss(A, B, np.eye(5), np.zeros((5, 2)), states=list(STATE_NAMES),
                inputs=list(INPUT_NAMES), outputs=list(STATE_NAMES), name="mwip")  # fmt: skip
    if Ts is None:
        return sys
    if not (isinstance(Ts, int | float) and np.isfinite(Ts) and Ts > 0):
        raise ValueError(f"Ts must be finite and in (0, inf), got {Ts!r}")
    return ct.sample_system(sys, Ts, method="zoh", name="mwip_zoh")


def state_from_q(
    q: NDArray[np.float64], qdot: NDArray[np.float64], r: float
) -> NDArray[np.float64]:
    """LQR state ``[theta, alpha, theta', v, alpha']`` from ``q, q'`` (..., 3) and wheel radius."""
    return np.stack([q[..., 1], q[..., 2], qdot[..., 1], r * qdot[..., 0], qdot[..., 2]], axis=-1)
