"""Linear-quadratic regulator about the upright equilibrium (Section 4.4.2).

State ``x = [theta, alpha, theta', v, alpha']``, input ``u = [u_r, u_l]``,
law ``u = -K (x - x_ref)``.

Two designs from the same weights (SPEC.md section 2):

- continuous (the book's): ``K = R^{-1} B^T P`` with ``A^T P + P A - P B R^{-1} B^T P + Q = 0``.
  With the book's ``Q = diag(1000, 100, 100, 100, 1000)``, ``R = 0.01 I`` the closed loop has
  poles near -1e5 rad/s: usable only in continuous time (``mode="continuous"``).
- sampled: the discrete Riccati equation on the zero-order-hold discretisation
  ``(Ad, Bd) = zoh(A, B, Ts)``; ``K = (R + Bd^T P Bd)^{-1} Bd^T P Ad``. This is what a 5 ms
  loop must use: the continuous gain applied with 5 ms hold is violently unstable.

The functions follow python-control's (and MATLAB's) signatures: :func:`lqr` on continuous
matrices, :func:`dlqr` on *discrete* ones (``dlqr(Ad, Bd, Q, R[, N])``), each returning
``(K, S, E)``; :func:`lqr_sampled` is "discretise (ZOH) then design", ``dlqr(*zoh(A, B, Ts),
Q, R)``. (The old ``dlqr(A, B, Q, R, Ts)`` on continuous matrices raises a ``TypeError``
naming :func:`lqr_sampled`: given discrete matrices it discretised them twice, silently.)

The book prints both rows of K equal; the yaw columns must flip sign between the wheels
(SPEC.md section 3). The design here gives rows ``[-223.99, +-70.71, -70.32, -23.12, +-218.99]``
on the nominal parameters.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.laws.packing import PackedLaw
from mwip.models.linear import linearize
from mwip.numerics import expm, solve_continuous_are, solve_discrete_are
from mwip.params import NOMINAL, Params
from mwip.validate import finite_array, real

__all__ = [
    "BOOK_Q", "BOOK_R", "lqr", "dlqr", "lqr_sampled", "zoh", "LQRDesign", "design_lqr", "LQR",
]  # fmt: skip

#: The book's weights (Section 4.4.2).
BOOK_Q = np.diag([1000.0, 100.0, 100.0, 100.0, 1000.0])
BOOK_R = np.diag([0.01, 0.01])


def _check_weights(Q: NDArray[np.float64], R: NDArray[np.float64], n: int, m: int) -> None:
    if Q.shape != (n, n) or not np.allclose(Q, Q.T) or np.min(np.linalg.eigvalsh(Q)) < -1e-12:
        raise ValueError(f"Q must be a symmetric positive semidefinite {n}x{n} matrix")
    if R.shape != (m, m) or not np.allclose(R, R.T) or np.min(np.linalg.eigvalsh(R)) <= 0:
        raise ValueError(f"R must be a symmetric positive definite {m}x{m} matrix")


def lqr(A: ArrayLike, B: ArrayLike, Q: ArrayLike, R: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """Continuous-time LQR: returns ``(K, P, E)`` (gain, Riccati solution, closed-loop poles)."""
    A, B, Q, R = (np.asarray(x, dtype=float) for x in (A, B, Q, R))
    _check_weights(Q, R, A.shape[0], B.shape[1])
    P = solve_continuous_are(A, B, Q, R)
    K = np.linalg.solve(R, B.T @ P)
    return K, P, np.linalg.eigvals(A - B @ K)


def zoh(A: ArrayLike, B: ArrayLike, Ts: float) -> tuple[NDArray, NDArray]:
    """Zero-order-hold discretisation: the block exponential ``expm([[A, B], [0, 0]] Ts)``."""
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    n, m = B.shape
    blk = np.zeros((n + m, n + m))
    blk[:n, :n], blk[:n, n:] = A, B
    E = expm(blk * Ts)
    return E[:n, :n], E[:n, n:]


def dlqr(
    A: Any, B: ArrayLike, Q: ArrayLike | None = None, R: ArrayLike | None = None,
    N: ArrayLike | None = None,
) -> tuple[NDArray, NDArray, NDArray]:  # fmt: skip
    """Discrete-time LQR on the discrete model ``x[k+1] = A x[k] + B u[k]``, python-control's
    ``dlqr(A, B, Q, R[, N])`` (also ``dlqr(sys, Q, R[, N])`` with a discrete state-space
    ``sys``): minimises ``sum x^T Q x + u^T R u + 2 x^T N u``. Returns ``(K, S, E)``: the gain
    of ``u = -K x``, the solution of the discrete Riccati equation and the closed-loop
    eigenvalues of ``A - B K`` (inside the unit circle).

    ``K = (R + B^T S B)^{-1} (B^T S A + N^T)``, ``S`` of
    ``A^T S A - S - (A^T S B + N)(R + B^T S B)^{-1}(B^T S A + N^T) + Q = 0`` (solved as the
    equation without cross term of ``A - B R^{-1} N^T``, ``Q - N R^{-1} N^T``).

    To design on a continuous model for a sample period, discretise first (``zoh``) or call
    :func:`lqr_sampled` ``(A, B, Q, R, Ts)``; a sample period given here as the fifth argument
    (the old ``dlqr(A, B, Q, R, Ts)``) raises a ``TypeError`` saying so.
    """
    if hasattr(A, "A") and hasattr(A, "B"):  # a state-space system (python-control's form)
        if getattr(A, "dt", None) == 0:
            raise ValueError("dlqr needs a discrete-time system (dt > 0); for a continuous one "
                             "call mwip.laws.lqr.lqr, or lqr_sampled(A, B, Q, R, Ts)")  # fmt: skip
        A, B, Q, R, N = A.A, A.B, B, Q, R
    if N is not None and np.ndim(N) == 0:
        raise TypeError(
            "mwip.laws.dlqr(A, B, Q, R, N) takes the discrete model and an (n, m) cross "
            f"weight N, as python-control's; got the number {N!r} as N. To discretise a "
            "continuous (A, B) at sample period Ts and design, call "
            "mwip.laws.lqr.controller.lqr_sampled(A, B, Q, R, Ts) (the former dlqr(A, B, Q, R, Ts))"
        )
    if Q is None or R is None:
        raise TypeError("dlqr(A, B, Q, R[, N]): give the weights Q and R")
    A, B, Q, R = (np.asarray(x, dtype=float) for x in (A, B, Q, R))
    n, m = B.shape
    _check_weights(Q, R, n, m)
    if N is None:
        S = solve_discrete_are(A, B, Q, R)
        K = np.linalg.solve(R + B.T @ S @ B, B.T @ S @ A)
    else:
        Nc = np.asarray(N, dtype=float)
        if Nc.shape != (n, m):
            raise ValueError(f"N must be a {n}x{m} matrix, got shape {Nc.shape}")
        RiNt = np.linalg.solve(R, Nc.T)
        S = solve_discrete_are(A - B @ RiNt, B, Q - Nc @ RiNt, R)
        K = np.linalg.solve(R + B.T @ S @ B, B.T @ S @ A + Nc.T)
    return K, S, np.linalg.eigvals(A - B @ K)


def lqr_sampled(
    A: ArrayLike, B: ArrayLike, Q: ArrayLike, R: ArrayLike, Ts: float
) -> tuple[NDArray, NDArray, NDArray]:
    """LQR for sample period ``Ts`` on the *continuous* ``(A, B)``: discretise by zero-order
    hold, then :func:`dlqr`, i.e. ``dlqr(*zoh(A, B, Ts), Q, R)``. Returns ``(K, S, z)``.

    ``z`` are the closed-loop eigenvalues of ``Ad - Bd K`` (inside the unit circle).
    The continuous cost is approximated by ``Q, R`` per sample (not scaled by Ts) as in the
    usual ``dlqr(c2d(sys), Q, R)`` practice (MATLAB's ``lqrd`` discretises the cost as well,
    and gives another gain).
    """
    if not (np.isfinite(Ts) and Ts > 0):
        raise ValueError(f"Ts must be finite and in (0, inf), got {Ts!r}")
    Ad, Bd = zoh(A, B, Ts)
    return dlqr(Ad, Bd, Q, R)


@dataclass(frozen=True)
class LQRDesign:
    """A designed gain: ``K`` (2, 5), its sample period (``None``: continuous), and poles.

    ``poles`` are continuous-time closed-loop poles (rad/s) for a continuous design and the
    discrete eigenvalues for a sampled one.
    """

    K: NDArray[np.float64]
    Ts: float | None
    Q: NDArray[np.float64]
    R: NDArray[np.float64]
    poles: NDArray[np.complex128]
    params: Params = field(repr=False)


def design_lqr(
    params: Params = NOMINAL,
    Q: ArrayLike = BOOK_Q,
    R: ArrayLike = BOOK_R,
    Ts: float | None = 0.005,
) -> LQRDesign:
    """Design the LQR on ``params`` (nominal by default); ``Ts=None`` gives the continuous gain.

    Bad arguments raise ``TypeError``/``ValueError`` naming the argument.
    """
    if not isinstance(params, Params):
        raise TypeError(f"params must be a mwip.params.Params, got {type(params).__name__}")
    if params.batch_shape != ():
        raise ValueError(f"params must be one robot, got a batch of shape {params.batch_shape}")
    if Ts is not None:
        Ts = real("Ts", Ts, 0.0, 1e3)
    Qa, Ra = finite_array("Q", Q), finite_array("R", R)
    for name, M in (("Q", Qa), ("R", Ra)):  # beyond, the Riccati iteration overflows
        if np.any(np.abs(M) > 1e12):
            raise ValueError(f"{name} must have entries in [-1e12, 1e12], got max |{name}| = "
                             f"{np.max(np.abs(M)):.3g}")  # fmt: skip
    A, B = linearize(params)
    K, _, poles = lqr(A, B, Qa, Ra) if Ts is None else lqr_sampled(A, B, Qa, Ra, Ts)
    return LQRDesign(K=K, Ts=Ts, Q=Qa, R=Ra, poles=poles, params=params)


class LQR:
    """State feedback ``u = -K (x - x_ref)`` on measured ``x = [theta, alpha, theta', v, alpha']``.

    ``v`` is formed from the measured wheel rate with the *nominal* radius, ``v = r_nom psi'``.
    Static (no internal state), so it also runs inside the right-hand side (continuous mode).
    """

    static = True

    def __init__(
        self,
        design: LQRDesign,
        reference: ArrayLike = (0.0, 0.0, 0.0, 0.0, 0.0),
    ) -> None:
        if not isinstance(design, LQRDesign):
            raise TypeError(f"design must be an LQRDesign, got {type(design).__name__}")
        self.K = np.asarray(design.K, dtype=float)
        self.Ts = design.Ts
        self.r_nominal = float(design.params.r)
        self.reference = finite_array("reference", reference)
        if self.reference.shape != (5,):
            raise ValueError(f"reference must have 5 entries, got shape {self.reference.shape}")
        # x = y[:, :6] @ sel with v = r_nom psi': fold the selection into the gain once
        sel = np.zeros((6, 5))
        sel[1, 0] = sel[2, 1] = sel[4, 2] = sel[5, 4] = 1.0
        sel[3, 3] = self.r_nominal
        self._sel = sel
        self._gain = np.ascontiguousarray(-sel @ self.K.T)  # (6, 2)
        self._offset = np.ascontiguousarray(self.reference @ self.K.T)  # (2,)

    def reset(self, meas: Measurement) -> None:
        """Nothing to reset (static law)."""

    def state(self, meas: Measurement) -> NDArray[np.float64]:
        """The LQR state from a measurement, (N, 5)."""
        return meas.y[:, :6] @ self._sel

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        # the kernel (Numba) is loaded when the Python loop calls the law (mwip.sim.aot)
        from mwip.laws.lqr.kernel import lqr_law

        y = np.ascontiguousarray(meas.y, dtype=float)
        return lqr_law(y, self._gain, self._offset, np.empty((y.shape[0], 2)))

    def packed_law(self) -> PackedLaw:
        """The law packed (:mod:`mwip.laws.lqr.packing`) for the compiled closed loop
        (:mod:`mwip.sim.loop`) and the C export: the same kernel."""
        from mwip.laws.lqr.packing import pack

        return pack(self._gain, self._offset)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return {}
