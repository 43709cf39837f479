"""Gain design of the high-order disturbance observer (Chapter 3.4).

The estimation error ``e = [tau~, tau~', ..., tau~^(n-1)]`` (3n,) of the n-th order observer
(3.20)-(3.23) obeys (3.31)-(3.32)

.. math::

    \\dot e = D_n e + E w, \\qquad w = \\tau_d^{(n)},

with the block companion matrix ``D_n`` (first block column ``-L_1 .. -L_n``, identity blocks
on the super-diagonal) and ``E = [0 ... 0 I3]^T``. The impulse-to-energy gain (3.35) is

.. math::

    ie = \\|E^T Y E\\|^{1/2}, \\qquad Y D_n + D_n^T Y + I = 0      \\quad (3.39), (3.41).

Gains are given as a sequence of n items, each a 3x3 array ``L_i`` or a scalar ``v_i``
meaning ``v_i I3`` (the book's published sets are all of that form).

Design functions
----------------
:func:`solve_ie_lmi` is the LMI problem (3.36)/(3.45)-(3.48) of Theorem 3.2::

    min alpha  s.t.  P A + A^T P + W B + B^T W^T + I  <  0
                     E^T P E  <=  alpha I3
                     P = P^T  >  0
    X = P^{-1} W = [-L_1; ...; -L_n],   ie <= sqrt(alpha).

(The extraction garbles the second constraint of (3.36); (3.45) states it as
``E^T P E <= alpha I3``, which is already linear in P, so no Schur complement is needed; the
book's ``min ie = alpha*`` lost a square root: ``ie = ||E^T P E||^{1/2}`` (3.43), so
``min ie = sqrt(alpha*)``.) Strict inequalities carry an explicit margin ``eps``.

As posed, the problem has **no minimiser**: ``ie -> 0`` as the observer poles go to infinity
(scaling all poles by ``w`` gives ``ie^2 ~ Y1_nn / w``), so the solver stops wherever its
tolerances and the margin ``eps`` let it, with astronomically large gains. This is why the
book's "optimal" set is impractical and why it then picks ``ie = 0.3`` designs. We therefore
also offer an optional pole-radius bound, the LMI region (Chilali-Gahinet disk)

.. math::

    \\begin{bmatrix} -rP & P D_n \\\\ D_n^T P & -rP \\end{bmatrix} < 0
    \\iff |\\lambda(D_n)| < r, \\qquad P D_n = P A + W B,

which bounds the gains (Vieta: ``|v_i| <= C(n, i) r^i`` for scalar gains) and the observer
bandwidth (what matters for sensor noise and for the sample period). :func:`design_for_ie`
poses the prescribed-ie design as: *the smallest radius r (to a relative tolerance) for which
the LMI certifies ie <= ie_target*, found by bisection on r of ``min alpha`` at fixed r (a
convex problem for each r, monotone in r); the gains are those of the optimum at that r,
and ``ie(gains)`` is recomputed and checked against the target.

Symmetry: the problem is invariant under ``e -> (I_n (x) Q) e`` for orthogonal 3x3 Q, so by
convexity an optimum of the form ``P = P_s (x) I3``, ``W = W_s (x) I3`` exists (average over
Q). ``structure="scalar"`` solves that n x n problem (exact, and faster) and lifts it;
``structure="full"`` solves the book's 3n x 3n problem literally.

Conditioning: with poles of size ``rho`` the entries of P span ``rho^-1 .. rho^-(2n-1)``; the
LMIs are solved after an exact diagonal congruence (:func:`_scaling`), which only changes the
meaning of ``eps`` (a margin in the scaled variables).

Published gains (SPEC.md sections 3-4): the book's printed ie values (1.8820e-6 for the
"optimal" 4th-order set, 0.3 for the three design sets) do not follow from the printed
definition; recomputed by (3.39)-(3.41) the sets give 0.259, 0.458, 0.540 and 0.293. See
:func:`compare_published` and ``docs/observers.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.numerics import solve_continuous_lyapunov

if TYPE_CHECKING:  # cvxpy is imported where an LMI is solved (it takes ~1 s to import)
    import cvxpy as cp

__all__ = [
    "GainsLike",
    "ObserverDesignError",
    "GainDesign",
    "PublishedGainSet",
    "PUBLISHED_GAIN_SETS",
    "as_gain_matrices",
    "stacked_gain",
    "error_dynamics",
    "lmi_matrices",
    "impulse_to_energy_gain",
    "solve_ie_lmi",
    "design_for_ie",
    "published_gain_sets",
    "compare_published",
    "format_comparison",
]

#: n gains, each a 3x3 matrix ``L_i`` or a scalar ``v_i`` meaning ``v_i I3``.
GainsLike = Sequence[ArrayLike]

Structure = Literal["full", "scalar"]


class ObserverDesignError(RuntimeError):
    """The LMI gain design failed (infeasible, solver failure, or a gain that fails checks)."""


# ---------------------------------------------------------------------------------------------
# Gains, error dynamics, impulse-to-energy gain
# ---------------------------------------------------------------------------------------------
def as_gain_matrices(gains: GainsLike) -> tuple[NDArray[np.float64], ...]:
    """Normalise gains to a tuple of n 3x3 float arrays ``L_1 .. L_n`` (3.24).

    A scalar ``v`` becomes ``v * I3``. Raises ``ValueError`` for an empty sequence, a wrong
    shape or a non-finite entry.
    """
    if isinstance(gains, str | bytes) or not isinstance(gains, Sequence | np.ndarray):
        raise ValueError(f"gains must be a sequence of 3x3 arrays or scalars, got {gains!r}")
    if len(gains) == 0:
        raise ValueError("gains must hold at least one gain (the observer order n >= 1)")
    out = []
    for i, g in enumerate(gains, start=1):
        a = np.asarray(g, dtype=float)
        if a.ndim == 0:
            a = float(a) * np.eye(3)
        if a.shape != (3, 3):
            raise ValueError(f"gain L_{i} must be a scalar or a 3x3 array, got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"gain L_{i} must be finite, got {a.tolist()}")
        out.append(a.copy())
    return tuple(out)


def stacked_gain(gains: GainsLike) -> NDArray[np.float64]:
    """The gains stacked into one (3n, 3) matrix ``[L_1; L_2; ...; L_n]`` (``= -X`` of (3.36))."""
    return np.vstack(as_gain_matrices(gains))


def _describe(gains: GainsLike) -> str:
    mats = as_gain_matrices(gains)
    if all(np.allclose(m, m[0, 0] * np.eye(3)) for m in mats):
        return "v = (" + ", ".join(f"{m[0, 0]:.6g}" for m in mats) + ") (L_i = v_i I3)"
    return "L = [" + "; ".join(np.array2string(m, precision=4) for m in mats) + "]"


def error_dynamics(gains: GainsLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Error dynamics ``(D_n, E)`` of the n-th order observer, (3.31)-(3.32).

    ``e' = D_n e + E w`` with ``e = [tau~, ..., tau~^(n-1)]`` and ``w = tau_d^(n)``.

    Returns
    -------
    D_n : (3n, 3n)
        Block companion: first block column ``-L_1, ..., -L_n``, ``I3`` on the block
        super-diagonal.
    E : (3n, 3)
        ``[0, ..., 0, I3]^T``.

    Examples
    --------
    >>> D, E = error_dynamics([3.0, 2.0])     # s^2 + 3 s + 2 = (s + 1)(s + 2), per channel
    >>> np.round(np.sort(np.linalg.eigvals(D).real), 6).tolist()
    [-2.0, -2.0, -2.0, -1.0, -1.0, -1.0]
    """
    mats = as_gain_matrices(gains)
    n = len(mats)
    D = np.zeros((3 * n, 3 * n))
    for i, L in enumerate(mats):
        D[3 * i : 3 * i + 3, 0:3] = -L  # first block column -L_i  (3.32)
        if i < n - 1:
            D[3 * i : 3 * i + 3, 3 * i + 3 : 3 * i + 6] = np.eye(3)  # super-diagonal I3
    E = np.zeros((3 * n, 3))
    E[-3:, :] = np.eye(3)
    return D, E


def lmi_matrices(
    n: int, m: int = 3
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Constant matrices ``A`` (mn, mn), ``B`` (m, mn) of (3.37) and ``E`` (mn, m) of (3.32).

    ``D_n = A + X B`` (3.46) with ``X = [-L_1; ...; -L_n]``. ``m = 3`` is the book's case;
    ``m = 1`` is the scalar channel used by ``structure="scalar"``.
    """
    if n < 1 or m < 1:
        raise ValueError(f"order n and block size m must be >= 1, got n={n}, m={m}")
    A = np.zeros((m * n, m * n))
    A[: m * (n - 1), m:] = np.eye(m * (n - 1))
    B = np.zeros((m, m * n))
    B[:, :m] = np.eye(m)
    E = np.zeros((m * n, m))
    E[-m:, :] = np.eye(m)
    return A, B, E


def _hurwitz_margin(D: NDArray[np.float64]) -> float:
    return float(np.max(np.linalg.eigvals(D).real))


def impulse_to_energy_gain(gains: GainsLike) -> float:
    """Impulse-to-energy gain ``ie = ||E^T Y E||^{1/2}`` of the error dynamics, (3.35).

    ``Y`` solves the Lyapunov equation ``Y D_n + D_n^T Y + I = 0`` (3.39); ``ie`` follows
    from (3.41)-(3.42) (spectral norm). For ``n = 1``, ``L = v I3``: ``ie = 1 / sqrt(2 v)``.

    Raises ``ValueError`` naming the gains if ``D_n`` is not Hurwitz (ie is then infinite).

    Examples
    --------
    >>> round(impulse_to_energy_gain([7.5213, 9755.8]), 4)    # the book's 2nd-order set
    0.2586
    """
    D, E = error_dynamics(gains)
    margin = _hurwitz_margin(D)
    if not margin < 0.0:
        raise ValueError(
            f"D_n is not Hurwitz for gains {_describe(gains)} (max Re(eig) = {margin:.4g}); "
            "the impulse-to-energy gain (3.35) is infinite"
        )
    Y = solve_continuous_lyapunov(D.T, -np.eye(D.shape[0]))  # D^T Y + Y D = -I  (3.39)
    Y = 0.5 * (Y + Y.T)
    return float(math.sqrt(np.linalg.norm(E.T @ Y @ E, 2)))  # (3.41)


# ---------------------------------------------------------------------------------------------
# LMI design (3.36)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GainDesign:
    """Result of an LMI gain design (3.36).

    Attributes
    ----------
    gains : tuple of n (3, 3) arrays
        ``L_1 .. L_n`` read off ``X = P^{-1} W = [-L_1; ...; -L_n]``.
    ie_lmi : float
        The LMI's certified bound ``sqrt(alpha)`` (>= ``ie`` up to solver tolerance).
    ie : float
        ``impulse_to_energy_gain(gains)``, recomputed from the gains (3.39)-(3.41).
    eigenvalues : (3n,) complex
        Eigenvalues of ``D_n`` (all with negative real part: checked).
    solver, status : str
        The cvxpy solver used and its status (``optimal`` or ``optimal_inaccurate``).
    alpha : float
        Optimal ``alpha`` of (3.36).
    P : (3n, 3n), W : (3n, 3)
        The LMI variables at the optimum (lifted to 3n when ``structure="scalar"``).
    radius : float or None
        Pole-radius bound used (None: the book's unbounded problem).
    eps : float
        Margin used for the strict inequalities (in the scaled problem).
    structure : "full" or "scalar"
    scale : float
        The preconditioning ``rho`` of the state scaling (1: the problem as printed).
    """

    gains: tuple[NDArray[np.float64], ...]
    ie_lmi: float
    ie: float
    eigenvalues: NDArray[np.complex128]
    solver: str
    status: str
    alpha: float
    P: NDArray[np.float64]
    W: NDArray[np.float64]
    radius: float | None
    eps: float
    structure: str
    scale: float = 1.0

    @property
    def order(self) -> int:
        """Observer order n."""
        return len(self.gains)

    @property
    def scalar_gains(self) -> tuple[float, ...] | None:
        """``(v_1, ..., v_n)`` if every ``L_i`` is ``v_i I3`` (to 1e-6 relative), else None."""
        v = []
        for L in self.gains:
            s = float(np.trace(L) / 3.0)
            if not np.allclose(L, s * np.eye(3), rtol=0.0, atol=1e-6 * max(abs(s), 1.0)):
                return None
            v.append(s)
        return tuple(v)


def _scaling(n: int, m: int, rho: float) -> tuple[NDArray[np.float64], float]:
    """Diagonal state scaling ``T = diag(1, 1/rho, ..., 1/rho^(n-1)) (x) I_m`` and ``c``.

    The LMIs are solved in the variables ``P^ = P_ / c``, ``W^`` with ``P = c T P^ T``,
    ``W = c T W^``, ``c = rho^(2(n-1))`` (a congruence with ``T^-1``: exact, it only
    preconditions the problem, since with poles of size ``rho`` the entries of P span
    ``rho^-1 .. rho^-(2n-1)``).
    """
    t = rho ** -np.arange(n, dtype=float)
    return np.asarray(np.kron(np.diag(t), np.eye(m)), float), float(rho ** (2 * (n - 1)))


def _build_problem(
    n: int, m: int, eps: float, with_radius: bool, rho: float
) -> tuple[cp.Problem, cp.Variable, cp.Variable, cp.Variable, cp.Parameter | None]:
    """The LMIs of (3.36) in scaled variables (see :func:`_scaling`).

    Scaled: ``P^ A~ + A~^T P^ + W^ B + B^T W^^T + T^-2 / c < 0`` with ``A~ = T A T^-1``,
    ``t_n^2 c E^T P^ E = E^T P^ E <= alpha I`` and the disk ``[[-r P^, P^ A~ + W^ B], ...]``.
    With ``rho = 1`` this is (3.36) literally.
    """
    import cvxpy as cp

    A, B, E = lmi_matrices(n, m)
    T, c = _scaling(n, m, rho)
    Tinv = np.diag(1.0 / np.diag(T))
    At = T @ A @ Tinv
    N = m * n
    P = cp.Variable((N, N), symmetric=True)
    W = cp.Variable((N, m))
    alpha = cp.Variable()
    lyap = P @ At + At.T @ P + W @ B + B.T @ W.T + (Tinv @ Tinv) / c  # (3.48), scaled
    cons = [
        0.5 * (lyap + lyap.T) << -eps * np.eye(N),  # strict < 0 with margin  (3.36)/(3.48)
        E.T @ P @ E << alpha * np.eye(m),  # E^T P E <= alpha I3  (3.45)  (t_n^2 c = 1)
        P >> eps * np.eye(N),  # P = P^T > 0  (3.45)
    ]
    r: cp.Parameter | None = None
    if with_radius:
        r = cp.Parameter(nonneg=True)
        PD = P @ At + W @ B  # P D_n  (3.46)-(3.47), scaled
        disk = cp.bmat([[-r * P, PD], [PD.T, -r * P]])
        cons.append(0.5 * (disk + disk.T) << -eps * np.eye(2 * N))
    return cp.Problem(cp.Minimize(alpha), cons), P, W, alpha, r


_OK_STATUS = ("optimal", "optimal_inaccurate")  # cvxpy's OPTIMAL, OPTIMAL_INACCURATE


def _finish(
    n: int,
    m: int,
    Ph: NDArray[np.float64],
    Wh: NDArray[np.float64],
    alpha: float,
    *,
    rho: float,
    solver: str,
    status: str,
    radius: float | None,
    eps: float,
    structure: str,
    what: str,
) -> GainDesign:
    """Read the gains off ``X = P^{-1} W`` (3.36), check them, and package the result.

    ``Ph, Wh`` are the scaled variables of :func:`_build_problem`.
    """
    if m == 1:  # lift the scalar-channel solution:  P = P_s (x) I3,  W = W_s (x) I3
        Ph = np.asarray(np.kron(Ph, np.eye(3)), float)
        Wh = np.asarray(np.kron(Wh, np.eye(3)), float)
    Ph = 0.5 * (Ph + Ph.T)
    if not (np.all(np.isfinite(Ph)) and np.all(np.isfinite(Wh)) and math.isfinite(alpha)):
        raise ObserverDesignError(f"{what}: the solver returned non-finite values")
    if np.min(np.linalg.eigvalsh(Ph)) <= 0.0:
        raise ObserverDesignError(f"{what}: P is not positive definite at the solution")
    T, c = _scaling(n, 3, rho)
    t = np.diag(T)
    X = np.linalg.solve(Ph, Wh) / t[:, None]  # X = P^{-1} W = T^-1 P^^-1 W^ = [-L_1; ...]
    gains = tuple(-X[3 * i : 3 * i + 3, :] for i in range(n))
    if not all(np.all(np.isfinite(g)) for g in gains):
        raise ObserverDesignError(f"{what}: non-finite gains")
    D, _ = error_dynamics(gains)
    eig = np.asarray(np.linalg.eigvals(D), complex)
    if not np.max(eig.real) < 0.0:
        raise ObserverDesignError(
            f"{what}: the returned gains do not make D_n Hurwitz (max Re = {np.max(eig.real):.3g})"
        )
    ie = impulse_to_energy_gain(gains)
    ie_lmi = math.sqrt(max(alpha, 0.0))
    # The LMI certifies ie <= sqrt(alpha) (3.43); a gross violation means a bad solution.
    if ie > ie_lmi * (1.0 + 1e-3) + 1e-9:
        raise ObserverDesignError(
            f"{what}: recomputed ie = {ie:.6g} exceeds the LMI bound {ie_lmi:.6g}"
        )
    return GainDesign(
        gains=gains,
        ie_lmi=ie_lmi,
        ie=ie,
        eigenvalues=eig,
        solver=solver,
        status=status,
        alpha=float(alpha),
        P=c * (t[:, None] * Ph * t[None, :]),  # P = c T P^ T
        W=c * (t[:, None] * Wh),  # W = c T W^
        radius=radius,
        eps=eps,
        structure=structure,
        scale=rho,
    )


def _check_args(n: int, eps: float, structure: str, radius: float | None) -> int:
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise ValueError(f"observer order n must be an integer >= 1, got {n!r}")
    if not (math.isfinite(eps) and eps > 0):
        raise ValueError(f"eps must be finite and > 0, got {eps!r}")
    if structure not in ("full", "scalar"):
        raise ValueError(f"structure must be 'full' or 'scalar', got {structure!r}")
    if radius is not None and not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0 (or None), got {radius!r}")
    return 3 if structure == "full" else 1


ProblemParts = tuple[Any, Any, Any, Any, Any]  # cvxpy Problem, P, W, alpha, radius


def _solve_scaled(
    n: int,
    m: int,
    eps: float,
    radius: float | None,
    rho: float,
    solver: str,
    solver_options: Mapping[str, Any] | None,
    what: str,
    parts: ProblemParts | None = None,
) -> tuple[str, NDArray[np.float64], NDArray[np.float64], float]:
    """Build (or reuse ``parts``) and solve the scaled LMI problem.

    Raises ``ObserverDesignError`` on a solver failure or a status other than optimal.
    """
    import cvxpy as cp

    prob, P, W, alpha, r = (
        parts if parts is not None else _build_problem(n, m, eps, radius is not None, rho)
    )
    if r is not None:
        r.value = float(radius)  # type: ignore[arg-type]
    try:
        prob.solve(solver=solver, **dict(solver_options or {}))
    except cp.error.SolverError as exc:
        raise ObserverDesignError(f"{what}: solver {solver} failed ({exc})") from None
    if prob.status not in _OK_STATUS or P.value is None or W.value is None:
        raise ObserverDesignError(f"{what}: solver {solver} returned status {prob.status!r}")
    return str(prob.status), np.asarray(P.value), np.asarray(W.value), float(alpha.value)  # type: ignore[arg-type]


def solve_ie_lmi(
    n: int,
    *,
    radius: float | None = None,
    eps: float = 1e-7,
    solver: str = "CLARABEL",
    structure: Structure = "full",
    scale: float | None = None,
    solver_options: Mapping[str, Any] | None = None,
) -> GainDesign:
    """Minimum impulse-to-energy gain by the LMI problem (3.36) (Theorem 3.2).

    ::

        min alpha  s.t.  P A + A^T P + W B + B^T W^T + I < 0              (3.36), (3.48)
                         E^T P E <= alpha I3                              (3.45)
                         P > 0                                            (3.45)
                         [[-r P, P A + W B], [(.)^T, -r P]] < 0           (only if radius=r)

    with ``A, B`` of (3.37); ``X = P^{-1} W = [-L_1; ...; -L_n]``, ``min ie = sqrt(alpha)``.
    Strict inequalities are posed as ``<= -eps I`` (``P >= eps I``) in the scaled variables
    of the preconditioning congruence (``scale``; see :func:`_scaling`).

    Parameters
    ----------
    n : int
        Observer order (>= 1).
    radius : float, optional
        Pole-radius bound ``r`` (rad/s): ``|eig(D_n)| < r``. ``None`` is the book's problem,
        which has no minimiser (ie -> 0 as the gains grow; see the module docstring): the
        result is then set by ``eps`` and the solver's tolerances, not by the problem.
    eps : float
        Margin of the strict inequalities.
    solver : str
        cvxpy solver name: ``"CLARABEL"`` (default) or ``"SCS"``.
    structure : "full" or "scalar"
        ``"full"``: the 3n x 3n problem as printed. ``"scalar"``: ``P = P_s (x) I3``,
        ``W = W_s (x) I3`` (exact by symmetry, faster); gains are then ``v_i I3``.
    scale : float, optional
        Preconditioning ``rho`` (rad/s, about the expected pole size); default ``radius``,
        or 1 (the problem exactly as printed) without a radius.

    Raises
    ------
    ObserverDesignError
        Infeasible or failed solve, or gains that fail the checks (P > 0, D_n Hurwitz,
        recomputed ie <= sqrt(alpha)).
    """
    m = _check_args(n, eps, structure, radius)
    rho = float(scale if scale is not None else (radius if radius is not None else 1.0))
    if not (math.isfinite(rho) and rho > 0):
        raise ValueError(f"scale must be finite and > 0, got {scale!r}")
    what = f"LMI (3.36), n={n}" + (f", radius={radius:g}" if radius is not None else "")
    status, Ph, Wh, alpha = _solve_scaled(n, m, eps, radius, rho, solver, solver_options, what)
    return _finish(
        n, m, Ph, Wh, alpha, rho=rho, solver=solver, status=status, radius=radius, eps=eps,
        structure=structure, what=what,
    )  # fmt: skip


def design_for_ie(
    n: int,
    ie_target: float,
    *,
    rtol: float = 1e-2,
    eps: float = 1e-7,
    solver: str = "CLARABEL",
    structure: Structure = "scalar",
    solver_options: Mapping[str, Any] | None = None,
) -> GainDesign:
    """Gains with ``ie <= ie_target`` and the smallest pole radius the LMI certifies.

    Posing (documented choice; the book picks ``ie = 0.3`` but does not say how): for a
    radius ``r`` let ``alpha*(r)`` be the optimum of :func:`solve_ie_lmi` with
    ``|eig(D_n)| < r`` ((3.36) plus the disk region). ``alpha*`` is non-increasing in ``r``;
    bisect (geometrically, to relative width ``rtol``) for the smallest ``r`` with
    ``sqrt(alpha*(r)) <= ie_target`` and return the optimum there. The pole radius bounds
    the gains (``|v_i| <= C(n, i) r^i``) and the bandwidth, so the design is the
    slowest / lowest-gain observer that the LMI certifies for the target. (The common
    Lyapunov matrix for the ie bound and the disk makes it conservative: the poles often
    end up inside ``r`` and ``ie`` below the target.)

    The returned ``ie`` (recomputed from the gains, (3.39)-(3.41)) is checked to be
    ``<= ie_target``; ``ObserverDesignError`` otherwise.

    Examples
    --------
    >>> d = design_for_ie(2, 0.3)
    >>> d.ie <= 0.3 and d.radius < 20.0
    True
    """
    if not (math.isfinite(ie_target) and ie_target > 0):
        raise ValueError(f"ie_target must be finite and > 0, got {ie_target!r}")
    if not (0 < rtol < 1):
        raise ValueError(f"rtol must be in (0, 1), got {rtol!r}")
    m = _check_args(n, eps, structure, None)
    base = f"design_for_ie(n={n}, ie_target={ie_target:g})"

    # One compiled problem per power-of-two scale rho (the radius is a cvxpy Parameter).
    built: dict[float, ProblemParts] = {}

    def solve_at(radius: float, what: str) -> tuple[float, str, NDArray, NDArray, float]:
        rho = float(2.0 ** round(math.log2(radius)))
        if rho not in built:
            built[rho] = _build_problem(n, m, eps, True, rho)
        out = _solve_scaled(n, m, eps, radius, rho, solver, solver_options, what, parts=built[rho])
        return (rho, *out)

    def attempt(radius: float) -> bool:
        try:
            alpha = solve_at(radius, base)[4]
        except ObserverDesignError:
            return False
        return math.sqrt(max(alpha, 0.0)) <= ie_target

    # n = 1: r = 1 / (2 ie^2) exactly; start every order's bracket there.
    hi = 1.0 / (2.0 * ie_target**2)
    lo = hi
    for _ in range(40):
        if attempt(hi):
            break
        lo, hi = hi, 2.0 * hi
    else:
        raise ObserverDesignError(f"{base}: no pole radius up to {hi:.3g} meets the target")
    if lo == hi:
        for _ in range(40):
            lo /= 2.0
            if not attempt(lo):
                break
            hi = lo
        else:
            raise ObserverDesignError(f"{base}: the radius bracket did not close")
    while hi / lo > 1.0 + rtol:
        mid = math.sqrt(lo * hi)
        if attempt(mid):
            hi = mid
        else:
            lo = mid
    what = f"{base}, radius={hi:.6g}"
    rho, status, Ph, Wh, alpha = solve_at(hi, what)
    out = _finish(
        n, m, Ph, Wh, alpha, rho=rho, solver=solver, status=status, radius=hi, eps=eps,
        structure=structure, what=what,
    )  # fmt: skip
    if not out.ie <= ie_target:
        raise ObserverDesignError(f"{what}: recomputed ie = {out.ie:.6g} > target")
    return out


# ---------------------------------------------------------------------------------------------
# The book's gain sets
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PublishedGainSet:
    """A gain set printed in the book: ``L_i = v_i I3`` (Section 3.6.1; SPEC.md section 4).

    ``ie_printed`` is the ie the book states for it; ``ie_spec`` the recomputed value given in
    SPEC.md section 3 (3 significant figures).
    """

    name: str
    v: tuple[float, ...]
    ie_printed: float | None
    ie_spec: float
    source: str

    def __post_init__(self) -> None:
        if len(self.v) < 1 or not all(math.isfinite(x) and x > 0 for x in self.v):
            raise ValueError(f"gain set {self.name!r}: v must be positive and finite, got {self.v}")

    @property
    def order(self) -> int:
        """Observer order n."""
        return len(self.v)

    @property
    def gains(self) -> tuple[NDArray[np.float64], ...]:
        """``(v_1 I3, ..., v_n I3)``."""
        return as_gain_matrices(list(self.v))


#: The book's printed gain sets (Sec. 3.6.1; Fig. 3.2 / Table 3.3 use do2, do3, do4).
PUBLISHED_GAIN_SETS: tuple[PublishedGainSet, ...] = (
    PublishedGainSet("do2", (7.5213, 9755.8), 0.3, 0.259, "Sec. 3.6.1, ie = 0.3 design"),
    PublishedGainSet("do3", (6.1211, 423.8938, 1078.3), 0.3, 0.458, "Sec. 3.6.1, ie = 0.3 design"),
    PublishedGainSet(
        "do4", (22.9778, 357.2853, 1831.5, 5737.7), 0.3, 0.540, "Sec. 3.6.1, ie = 0.3 design"
    ),
    PublishedGainSet(
        "do4_optimal",
        (47.1084, 1960.1, 36256.0, 393980.0),
        1.8820e-6,
        0.293,
        "Sec. 3.6.1, 'optimal' solution of (3.36)",
    ),
)


def published_gain_sets() -> dict[str, PublishedGainSet]:
    """The book's gain sets by name: ``do2``, ``do3``, ``do4``, ``do4_optimal``."""
    return {s.name: s for s in PUBLISHED_GAIN_SETS}


def compare_published() -> list[dict[str, Any]]:
    """Table of the published sets: printed ie vs ie recomputed by (3.39)-(3.41).

    Each row: ``name, order, v, ie_printed, ie_spec, ie (ours), max_abs_eig, min_damping``
    (``min_damping`` = min over poles of ``-Re(l)/|l|``).
    """
    rows = []
    for s in PUBLISHED_GAIN_SETS:
        D, _ = error_dynamics(list(s.v))
        eig = np.linalg.eigvals(D)
        rows.append(
            {
                "name": s.name,
                "order": s.order,
                "v": s.v,
                "ie_printed": s.ie_printed,
                "ie_spec": s.ie_spec,
                "ie": impulse_to_energy_gain(list(s.v)),
                "max_abs_eig": float(np.max(np.abs(eig))),
                "min_damping": float(np.min(-eig.real / np.abs(eig))),
            }
        )
    return rows


def format_comparison(rows: Sequence[Mapping[str, Any]] | None = None) -> str:
    """Markdown table of :func:`compare_published` rows."""
    rows = compare_published() if rows is None else rows
    lines = [
        "| set | v | ie printed | ie SPEC | ie ours | max abs eig (rad/s) | min damping |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        printed = "-" if r["ie_printed"] is None else f"{r['ie_printed']:.5g}"
        v = ", ".join(f"{x:g}" for x in r["v"])
        lines.append(
            f"| {r['name']} | ({v}) | {printed} | {r['ie_spec']:.3g} | {r['ie']:.4f} "
            f"| {r['max_abs_eig']:.4g} | {r['min_damping']:.3f} |"
        )
    return "\n".join(lines)
