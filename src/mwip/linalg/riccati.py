"""Stabilising solutions of the continuous and discrete algebraic Riccati equations.

CARE (SciPy's ``solve_continuous_are(a, b, q, r)``), with ``G = B R^{-1} B^T``:

.. math::

    A^T X + X A - X G X + Q = 0, \\qquad A - G X \\ \\text{Hurwitz}.

DARE (``solve_discrete_are(a, b, q, r)``):

.. math::

    A^T X A - X - A^T X B (R + B^T X B)^{-1} B^T X A + Q = 0
    \\iff X = Q + A^T X (I + G X)^{-1} A,

with ``A - B (R + B^T X B)^{-1} B^T X A`` Schur stable (eigenvalues inside the unit circle).

Method: the structure-preserving doubling algorithm (SDA). For the DARE (E. K.-W. Chu,
H.-Y. Fan, W.-W. Lin, C.-S. Wang, "Structure-preserving algorithms for periodic discrete-time
algebraic Riccati equations", Int. J. Control 77(8):767-788, 2004), from
``A_0 = A, G_0 = G, H_0 = Q``:

.. math::

    W_k = I + G_k H_k, \\quad A_{k+1} = A_k W_k^{-1} A_k, \\quad
    G_{k+1} = G_k + A_k W_k^{-1} G_k A_k^T, \\quad H_{k+1} = H_k + A_k^T H_k W_k^{-1} A_k,

and ``H_k -> X`` quadratically, ``||H_k - X|| = O(rho^{2^k})`` with ``rho`` the spectral
radius of the closed loop. For the CARE (E. K.-W. Chu, H.-Y. Fan, W.-W. Lin, "A
structure-preserving doubling algorithm for continuous-time algebraic Riccati equations",
Linear Algebra Appl. 396:55-80, 2005) the Cayley transform with ``gamma > 0`` maps the
Hamiltonian ``[[A, -G], [-Q, -A^T]]`` to the same form, with ``A_g = A - gamma I``,
``W_g = A_g^T + Q A_g^{-1} G``:

.. math::

    A_0 = I + 2\\gamma W_g^{-T}, \\quad G_0 = 2\\gamma A_g^{-1} G W_g^{-1}, \\quad
    H_0 = 2\\gamma W_g^{-1} Q A_g^{-1},

and the closed-loop poles ``lambda`` become ``(lambda + gamma) / (lambda - gamma)``. We pick
``gamma`` among values spread geometrically over the range of the stable eigenvalues of the
Hamiltonian to make ``rho = max |(lambda + gamma) / (lambda - gamma)|`` small. The doubling
result is then refined by Newton's method in correction form (D. L. Kleinman, IEEE TAC
13:114-115, 1968, for the CARE; G. A. Hewer, IEEE TAC 16:382-384, 1971, for the DARE): a
Lyapunov (Stein) equation in the closed loop for the correction ``Delta`` of the residual,
kept while the residual decreases, so that the answer is as accurate as the equation's
conditioning allows. The doubling iteration also needs the dual equation to have a solution,
i.e. ``(A, Q)`` detectable; where it fails (an unobservable mode of ``(A, Q)`` off the
stability boundary, e.g. a rank-deficient ``Q``), the stable invariant subspace is found by
the matrix sign function instead (:func:`_sign_subspace`), then refined the same way (tried
first when a PBH test finds an unstable mode of ``(A, Q)`` unobservable). A start is taken
only if its refined result stabilises the closed loop and leaves a relative residual below
1e-8.

Failures raise ``ValueError``: ``(A, B)`` not stabilisable (a PBH rank test on the unstable
eigenvalues of ``A``), Hamiltonian eigenvalues on the imaginary axis / an unobservable mode
of ``(A, Q)`` on the unit circle (no stabilising solution), no convergence, or a result that
does not stabilise the closed loop. ``R`` must be symmetric positive definite (SciPy also
accepts an indefinite, nonsingular ``R``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.linalg._check import matrix, square
from mwip.linalg.lyapunov import solve_continuous_lyapunov, solve_discrete_lyapunov

__all__ = ["solve_continuous_are", "solve_discrete_are"]

_EPS = float(np.finfo(float).eps)
_MAX_DOUBLINGS = 64
_MAX_NEWTON = 4
_CONVERGED = 1e-12  # relative change of H_k after which one more doubling step is taken
_RESIDUAL_OK = 1e-8  # relative residual above which the result is refused


def _sym(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return 0.5 * (x + x.T)


def _norm(x: NDArray[np.float64]) -> float:
    return float(np.abs(x).sum(axis=0).max()) if x.size else 0.0


def _operands(
    a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike
) -> tuple[NDArray[np.float64], ...]:
    """Checked ``(A, B, Q, R, G)`` with ``G = B R^{-1} B^T``."""
    A = square("a", a, complex_ok=False)
    n = A.shape[0]
    if n == 0:
        raise ValueError("a must be at least 1x1, got shape (0, 0)")
    B = matrix("b", b, n)
    m = B.shape[1]
    Q = matrix("q", q, n, n)
    R = matrix("r", r, m, m)
    if not np.allclose(Q, Q.T, rtol=1e-12, atol=1e-14 * max(_norm(Q), 1e-300)):
        raise ValueError("q must be symmetric")
    if not np.allclose(R, R.T, rtol=1e-12, atol=1e-14 * max(_norm(R), 1e-300)):
        raise ValueError("r must be symmetric")
    try:
        np.linalg.cholesky(_sym(R))
    except np.linalg.LinAlgError:
        raise ValueError("r must be positive definite") from None
    G = _sym(B @ np.linalg.solve(_sym(R), B.T))
    return A, B, _sym(Q), _sym(R), G


def _pbh_unstable_uncontrollable(
    A: NDArray[np.float64], B: NDArray[np.float64], unstable: NDArray
) -> complex | None:
    """An eigenvalue in ``unstable`` where ``rank [A - lambda I, B] < n`` (PBH), else ``None``."""
    n = A.shape[0]
    scale = _norm(A) + _norm(B)
    for lam in unstable:
        blk = np.hstack([A - lam * np.eye(n), B])
        smin = np.linalg.svd(blk, compute_uv=False)[-1]
        if smin <= 1e3 * n * _EPS * (scale + abs(lam)):
            return complex(lam)
    return None


def _doubling(
    A0: NDArray[np.float64], G0: NDArray[np.float64], H0: NDArray[np.float64], what: str
) -> NDArray[np.float64]:
    """SDA iteration (module docstring) from ``(A0, G0, H0)``; returns ``H_k -> X``."""
    n = A0.shape[0]
    eye = np.eye(n)
    Ak, Gk, Hk = A0, G0, H0
    converged = False
    for _ in range(_MAX_DOUBLINGS):
        try:
            S = np.linalg.solve(eye + Gk @ Hk, np.hstack([Ak, Gk]))  # W_k^{-1} [A_k, G_k]
        except np.linalg.LinAlgError:
            raise ValueError(f"{what}: the doubling iteration broke down "
                             "(I + G_k H_k singular)") from None  # fmt: skip
        WA, WG = S[:, :n], S[:, n:]
        H_next = _sym(Hk + Ak.T @ Hk @ WA)
        Gk = _sym(Gk + Ak @ WG @ Ak.T)
        Ak = Ak @ WA
        if _norm(Ak) > 1e100:  # the dual solution does not exist: (A, Q) not detectable
            raise ValueError(f"{what}: the doubling iteration diverged (A_k unbounded)")
        if not (np.all(np.isfinite(H_next)) and np.all(np.isfinite(Gk))):
            raise ValueError(f"{what}: the doubling iteration diverged (no stabilising solution)")
        change = _norm(H_next - Hk)
        Hk = H_next
        if converged:
            return Hk
        converged = change <= _CONVERGED * max(_norm(Hk), np.finfo(float).tiny)
    raise ValueError(f"{what}: the doubling iteration did not converge in {_MAX_DOUBLINGS} steps "
                     "(closed-loop poles on the stability boundary?)")  # fmt: skip


def _cayley(
    A: NDArray[np.float64],
    G: NDArray[np.float64],
    Q: NDArray[np.float64],
    stable: NDArray,
    what: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """SDA start ``(A_0, G_0, H_0)`` for the CARE (Chu, Fan, Lin 2005; module docstring).

    ``gamma`` is tried over 25 values spread geometrically over ``|stable|`` (the stable
    eigenvalues of the Hamiltonian, i.e. the closed-loop poles), best convergence factor
    ``rho = max |(lambda + gamma) / (lambda - gamma)|`` first, skipping values where
    ``A - gamma I`` or ``W_gamma`` is ill-conditioned.
    """
    n = A.shape[0]
    mags = np.abs(stable)
    cands = np.geomspace(mags.min(), mags.max(), 25) if mags.max() > mags.min() else mags[:1]
    rho = np.max(np.abs((stable[None, :] + cands[:, None]) / (stable[None, :] - cands[:, None])),
                 axis=1)  # fmt: skip
    eye = np.eye(n)
    for gamma in cands[np.argsort(rho)]:
        Ag = A - gamma * eye
        if np.linalg.cond(Ag) > 1.0 / np.sqrt(_EPS):
            continue
        Wg = Ag.T + Q @ np.linalg.solve(Ag, G)
        if np.linalg.cond(Wg) > 1.0 / np.sqrt(_EPS):
            continue
        A0 = eye + 2.0 * gamma * np.linalg.inv(Wg).T
        G0 = _sym(2.0 * gamma * np.linalg.solve(Ag, G) @ np.linalg.inv(Wg))
        H0 = _sym(2.0 * gamma * np.linalg.solve(Wg, Q) @ np.linalg.inv(Ag))
        return A0, G0, H0
    raise ValueError(f"{what}: no Cayley parameter gives well-conditioned A - gamma I and W")


def _care_residual(A: NDArray, G: NDArray, Q: NDArray, X: NDArray) -> NDArray[np.float64]:
    return _sym(A.T @ X + X @ A - X @ G @ X + Q)


def _dare_residual(A: NDArray, B: NDArray, Q: NDArray, R: NDArray, X: NDArray) -> NDArray:
    BX = B.T @ X
    return _sym(A.T @ X @ A - X - (BX @ A).T @ np.linalg.solve(R + BX @ B, BX @ A) + Q)


def solve_continuous_are(a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike) -> NDArray:
    """The stabilising ``X`` of ``A^T X + X A - X B R^{-1} B^T X + Q = 0`` (SciPy's convention).

    SDA with Cayley parameter ``gamma`` (the sign function where it fails) and Newton
    refinement (module docstring). Raises
    ``ValueError`` when ``(A, B)`` is not stabilisable, the Hamiltonian has eigenvalues on the
    imaginary axis, or the iteration fails.
    """
    A, B, Q, R, G = _operands(a, b, q, r)
    n = A.shape[0]
    what = "continuous Riccati equation"
    lam_a = np.linalg.eigvals(A)
    bad = _pbh_unstable_uncontrollable(A, B, lam_a[lam_a.real >= 0.0])
    if bad is not None:
        raise ValueError(f"{what}: (A, B) is not stabilisable (uncontrollable mode {bad:.6g})")
    ham = np.block([[A, -G], [-Q, -A.T]])
    lam = np.linalg.eigvals(ham)
    if np.min(np.abs(lam.real)) <= 1e2 * 2 * n * _EPS * _norm(ham):
        raise ValueError(
            f"{what}: the Hamiltonian has eigenvalues on the imaginary axis "
            "(a mode of (A, Q) unobservable there): no stabilising solution"
        )

    def residual(x: NDArray) -> NDArray:
        return _care_residual(A, G, Q, x)

    def correction(x: NDArray, res: NDArray) -> NDArray:
        return solve_continuous_lyapunov((A - G @ x).T, -res)  # Ac^T D + D Ac = -Res

    def max_pole(x: NDArray) -> float:
        return float(np.max(np.linalg.eigvals(A - G @ x).real))

    def doubling() -> NDArray:
        return _doubling(*_cayley(A, G, Q, lam[lam.real < 0.0], what), what)

    def sign() -> NDArray:
        return _sign_subspace(ham, what)

    detectable = _pbh_unstable_uncontrollable(A.T, Q, lam_a[lam_a.real >= 0.0]) is None
    return _first_stabilising(
        (doubling, sign) if detectable else (sign, doubling),
        residual,
        correction,
        lambda x: max_pole(x) < 0.0,
        lambda x: _norm(Q) + 2 * _norm(A) * _norm(x) + _norm(G) * _norm(x) ** 2,
        what,
    )


def solve_discrete_are(a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike) -> NDArray:
    """The stabilising ``X`` of ``A^T X A - X - A^T X B (R + B^T X B)^{-1} B^T X A + Q = 0``.

    SciPy's convention. SDA (the sign function where it fails) and Newton refinement (module
    docstring). Raises ``ValueError``
    when ``(A, B)`` is not stabilisable, ``(A, Q)`` has an unobservable mode on the unit circle,
    or the iteration fails.
    """
    A, B, Q, R, G = _operands(a, b, q, r)
    what = "discrete Riccati equation"
    lam_a = np.linalg.eigvals(A)
    bad = _pbh_unstable_uncontrollable(A, B, lam_a[np.abs(lam_a) >= 1.0])
    if bad is not None:
        raise ValueError(f"{what}: (A, B) is not stabilisable (uncontrollable mode {bad:.6g})")
    on_circle = lam_a[np.abs(np.abs(lam_a) - 1.0) <= 1e3 * A.shape[0] * _EPS * max(_norm(A), 1)]
    bad = _pbh_unstable_uncontrollable(A.T, Q, on_circle)  # PBH on (A^T, Q): observability
    if bad is not None:
        raise ValueError(f"{what}: (A, Q) has an unobservable mode {bad:.6g} on the unit circle: "
                         "no stabilising solution")  # fmt: skip

    def residual(x: NDArray) -> NDArray:
        return _dare_residual(A, B, Q, R, x)

    def closed_loop(x: NDArray) -> NDArray:
        BX = B.T @ x
        return A - B @ np.linalg.solve(R + BX @ B, BX @ A)

    def correction(x: NDArray, res: NDArray) -> NDArray:
        Ac = closed_loop(x)
        return solve_discrete_lyapunov(Ac.T, res)  # Ac^T D Ac - D + Res = 0

    def cayley_of_pencil() -> NDArray:
        n = A.shape[0]
        M = np.block([[A, np.zeros((n, n))], [-Q, np.eye(n)]])
        L = np.block([[np.eye(n), G], [np.zeros((n, n)), A.T]])
        try:
            return np.linalg.solve(M + L, M - L)
        except np.linalg.LinAlgError:
            raise ValueError(f"{what}: the pencil has the eigenvalue -1") from None

    def doubling() -> NDArray:
        return _doubling(A, G, Q, what)

    def sign() -> NDArray:
        return _sign_subspace(cayley_of_pencil(), what)

    detectable = _pbh_unstable_uncontrollable(A.T, Q, lam_a[np.abs(lam_a) >= 1.0]) is None
    return _first_stabilising(
        (doubling, sign) if detectable else (sign, doubling),
        residual,
        correction,
        lambda x: float(np.max(np.abs(np.linalg.eigvals(closed_loop(x))))) < 1.0,
        lambda x: (
            _norm(Q) + (_norm(A) ** 2 + 1) * _norm(x) + _norm(A) ** 2 * _norm(G) * _norm(x) ** 2
        ),
        what,
    )


def _sign_subspace(Z: NDArray[np.float64], what: str) -> NDArray[np.float64]:
    """``X`` with ``span [I; X]`` the stable invariant subspace of ``Z`` (2n x 2n), by the
    matrix sign function (the fallback when the doubling iteration fails).

    Newton's iteration ``Z <- (Z / c + c Z^{-1}) / 2`` with determinant scaling
    ``c = |det Z|^{1/2n}`` (R. Byers, "Solving the algebraic Riccati equation with the matrix
    sign function", Linear Algebra Appl. 85:267-279, 1987) converges to ``S = sign(Z)``; the
    stable subspace is the kernel of ``S + I``, so ``[S_12; S_22 + I] X = -[S_11 + I; S_21]``
    (J. D. Gardiner, A. J. Laub, Int. J. Control 44:823-832, 1986), solved in least squares.
    Unlike the doubling iteration it needs no dual solution, i.e. it also works when ``(A, Q)``
    has unobservable modes off the stability boundary. For the CARE ``Z`` is the Hamiltonian;
    for the DARE the Cayley transform ``(M + L)^{-1} (M - L)`` of the symplectic pencil
    ``M - z L`` (``M = [[A, 0], [-Q, I]]``, ``L = [[I, G], [0, A^T]]``), which maps the inside
    of the unit circle to the left half-plane.
    """
    N = Z.shape[0]
    n = N // 2
    scale = True
    converged = False
    for _ in range(100):
        sign, logdet = np.linalg.slogdet(Z)
        if sign == 0 or not np.isfinite(logdet):
            raise ValueError(f"{what}: the sign iteration broke down (singular iterate)")
        c = float(np.exp(logdet / N)) if scale else 1.0
        Z_next = 0.5 * (Z / c + c * np.linalg.inv(Z))
        change = _norm(Z_next - Z)
        Z = Z_next
        if converged:
            break
        scale = change > 1e-2 * _norm(Z)
        converged = change <= 1e-12 * _norm(Z)
    else:
        raise ValueError(f"{what}: the sign iteration did not converge")
    eye = np.eye(n)
    lhs = np.vstack([Z[:n, n:], Z[n:, n:] + eye])
    rhs = -np.vstack([Z[:n, :n] + eye, Z[n:, :n]])
    X = np.asarray(np.linalg.lstsq(lhs, rhs, rcond=None)[0], dtype=np.float64)
    if not np.all(np.isfinite(X)):
        raise ValueError(f"{what}: the sign iteration gave a non-finite solution")
    return _sym(X)


def _first_stabilising(
    starts: tuple[Callable[[], NDArray], ...],
    residual: Callable[[NDArray], NDArray],
    correction: Callable[[NDArray, NDArray], NDArray],
    stabilises: Callable[[NDArray], bool],
    scale: Callable[[NDArray], float],
    what: str,
) -> NDArray:
    """The first start that, Newton-refined, stabilises the closed loop and solves the
    equation (relative residual ``||Res|| / scale(X) <= 1e-8``; round-off is ~1e-16)."""
    reasons = []
    for start in starts:
        try:
            X = _newton(start(), residual, correction)
        except ValueError as exc:
            reasons.append(str(exc).removeprefix(f"{what}: "))
            continue
        rel = _norm(residual(X)) / max(scale(X), np.finfo(float).tiny)
        if not stabilises(X):
            reasons.append("the result does not stabilise the closed loop")
        elif not rel <= _RESIDUAL_OK:
            reasons.append(f"the result is inaccurate (relative residual {rel:.3g})")
        else:
            return X
    raise ValueError(f"{what}: no stabilising solution found ({'; '.join(reasons)})")


def _newton(
    X: NDArray,
    residual: Callable[[NDArray], NDArray],
    correction: Callable[[NDArray, NDArray], NDArray],
) -> NDArray:
    """Newton steps ``X + Delta`` (Kleinman / Hewer, correction form) while the residual drops."""
    res = residual(X)
    size = _norm(res)
    for _ in range(_MAX_NEWTON):
        if size == 0.0:
            break
        try:
            X_new = _sym(X + correction(X, res))
        except ValueError:
            break
        res_new = residual(X_new)
        size_new = _norm(res_new)
        if not size_new < size:
            break
        X, res, size = X_new, res_new, size_new
    return X
