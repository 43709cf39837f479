"""SciPy's dense solvers for the design steps, each result checked and cached.

The designs (LQR gains, the zero-order-hold model, the disturbance observer's discretisation
and its impulse-to-energy gain) need four functions of :mod:`scipy.linalg`:
``solve_continuous_are``, ``solve_discrete_are``, ``expm`` and
``solve_continuous_lyapunov``. Each wrapper here

- imports :mod:`scipy.linalg` inside the function, only when it has to solve
  (``import scipy.linalg`` costs ~0.12 s of start-up);
- checks SciPy's answer (a relative residual below :data:`RTOL`, and for the Riccati
  equations a stabilising closed loop: SciPy can return a non-stabilising solution where none
  exists) and raises a :class:`NumericsError` subclass naming the check that failed;
- keeps the checked answer in mwip's design cache (:mod:`mwip.cache`, kind ``numerics``),
  named by a hash of this file, SciPy's and NumPy's versions and the input arrays, so a warm
  ``mwip simulate`` reads it back (checked again) without importing SciPy, as the IT2 designs
  do (:func:`mwip.fuzzy.pdc.design_pdc`). ``MWIP_CACHE=off`` always solves.

Equations (SciPy's conventions, ``G = B R^{-1} B^T``):

- CARE: ``A^T X + X A - X G X + Q = 0`` with ``A - G X`` Hurwitz;
- DARE: ``A^T X A - X - A^T X B (R + B^T X B)^{-1} B^T X A + Q = 0`` with
  ``A - B (R + B^T X B)^{-1} B^T X A`` Schur stable;
- Lyapunov: ``A X + X A^T = Q``;
- ``expm(M)``, checked by its commutation with ``M`` (``M e^M = e^M M``).

The relative residual is the residual's norm over the sum of the norms of the equation's
terms (the size of the rounding errors made in forming them).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "RTOL", "NumericsError", "RiccatiError", "LyapunovError", "MatrixExponentialError",
    "solve_continuous_are", "solve_discrete_are", "solve_continuous_lyapunov", "expm",
]  # fmt: skip

#: Relative residual above which an answer is refused.
RTOL = 1e-8

Array = NDArray[np.float64]


class NumericsError(ValueError):
    """A dense solver failed or its answer failed its check (one line: which and why)."""


class RiccatiError(NumericsError):
    """No stabilising solution of a Riccati equation, or SciPy's answer fails the residual or
    the closed-loop stability check."""


class LyapunovError(NumericsError):
    """A Lyapunov equation without a unique solution, or an answer that fails its residual."""


class MatrixExponentialError(NumericsError):
    """A matrix exponential that is not finite or does not commute with its argument."""


def _norm(x: NDArray[np.floating]) -> float:
    return float(np.abs(x).sum(axis=0).max()) if x.size else 0.0


def _square(name: str, a: ArrayLike) -> Array:
    out = np.asarray(a, dtype=float)
    if out.ndim != 2 or out.shape[0] != out.shape[1] or out.shape[0] == 0:
        raise ValueError(f"{name} must be a non-empty square matrix, got shape {out.shape}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite")
    return out


def _riccati_operands(a: ArrayLike, b: ArrayLike, q: ArrayLike,
                      r: ArrayLike) -> tuple[Array, Array, Array, Array]:  # fmt: skip
    A, Q, R = _square("a", a), _square("q", q), _square("r", r)
    B = np.asarray(b, dtype=float)
    n, m = A.shape[0], R.shape[0]
    if B.shape != (n, m) or not np.all(np.isfinite(B)):
        raise ValueError(f"b must be a finite {n}x{m} matrix, got shape {B.shape}")
    if Q.shape != (n, n):
        raise ValueError(f"q must be {n}x{n}, got shape {Q.shape}")
    return A, B, Q, R


# ---------------------------------------------------------------------------------------------
# Checks (NumPy only: they run on a cached answer too)
# ---------------------------------------------------------------------------------------------
def _check_finite(what: str, X: Array, error: type[NumericsError]) -> None:
    if not np.all(np.isfinite(X)):
        raise error(f"{what}: SciPy returned non-finite values")


def _check_care(A: Array, B: Array, Q: Array, R: Array, X: Array) -> None:
    what = "continuous Riccati equation"
    _check_finite(what, X, RiccatiError)
    G = B @ np.linalg.solve(R, B.T)
    res = A.T @ X + X @ A - X @ G @ X + Q
    scale = _norm(Q) + 2.0 * _norm(A) * _norm(X) + _norm(G) * _norm(X) ** 2
    rel = _norm(res) / max(scale, np.finfo(float).tiny)
    if not rel <= RTOL:
        raise RiccatiError(f"{what}: relative residual {rel:.3g} > {RTOL:g}")
    lam = np.linalg.eigvals(A - G @ X)
    if not float(np.max(lam.real)) < 0.0:
        raise RiccatiError(f"{what}: the solution does not stabilise the closed loop "
                           f"(max Re(eig) = {np.max(lam.real):.4g})")  # fmt: skip


def _check_dare(A: Array, B: Array, Q: Array, R: Array, X: Array) -> None:
    what = "discrete Riccati equation"
    _check_finite(what, X, RiccatiError)
    BX = B.T @ X
    S = R + BX @ B
    K = np.linalg.solve(S, BX @ A)
    res = A.T @ X @ A - X - (BX @ A).T @ K + Q
    scale = (_norm(Q) + _norm(X) + _norm(A) ** 2 * _norm(X)
             + _norm(BX @ A) * _norm(K))  # fmt: skip
    rel = _norm(res) / max(scale, np.finfo(float).tiny)
    if not rel <= RTOL:
        raise RiccatiError(f"{what}: relative residual {rel:.3g} > {RTOL:g}")
    rho = float(np.max(np.abs(np.linalg.eigvals(A - B @ K))))
    if not rho < 1.0:
        raise RiccatiError(f"{what}: the solution does not stabilise the closed loop "
                           f"(spectral radius {rho:.4g})")  # fmt: skip


def _check_unique(A: Array) -> None:
    """``A X + X A^T`` is singular where two eigenvalues of ``A`` sum to zero (SciPy then
    perturbs the data and returns an answer whose residual can still look small)."""
    lam = np.linalg.eigvals(A)
    sep = float(np.min(np.abs(lam[:, None] + lam[None, :])))
    if not sep > 1e3 * np.finfo(float).eps * max(_norm(A), np.finfo(float).tiny):
        raise LyapunovError("Lyapunov equation: two eigenvalues of A sum to zero "
                            f"(min |l_i + l_j| = {sep:.3g}): no unique solution")  # fmt: skip


def _check_lyapunov(A: Array, Q: Array, X: Array) -> None:
    what = "Lyapunov equation"
    _check_unique(A)
    _check_finite(what, X, LyapunovError)
    res = A @ X + X @ A.T - Q
    scale = 2.0 * _norm(A) * _norm(X) + _norm(Q)
    rel = _norm(res) / max(scale, np.finfo(float).tiny)
    if not rel <= RTOL:
        raise LyapunovError(f"{what}: relative residual {rel:.3g} > {RTOL:g}")


def _check_expm(M: Array, E: Array) -> None:
    what = "matrix exponential"
    _check_finite(what, E, MatrixExponentialError)
    rel = _norm(M @ E - E @ M) / max(2.0 * _norm(M) * _norm(E), np.finfo(float).tiny)
    if not rel <= RTOL:
        raise MatrixExponentialError(f"{what}: e^M does not commute with M (relative "
                                     f"{rel:.3g} > {RTOL:g})")


# ---------------------------------------------------------------------------------------------
# Cache
# ---------------------------------------------------------------------------------------------
_MEMO: dict[str, Array] = {}
_PREFIX: list[str] = []


def _prefix() -> str:
    """The part of every cache name that is fixed in a process: this file and the SciPy and
    NumPy versions (read once)."""
    if not _PREFIX:
        from mwip.cache import digest, versions

        _PREFIX.append(digest([Path(__file__), *versions(["scipy", "numpy"])]))
    return _PREFIX[0]


def _cached(kind: str, inputs: tuple[Array, ...], solve: Callable[[], Array],
            check: Callable[[Array], None]) -> Array:  # fmt: skip
    """``solve()``'s checked answer for ``inputs``, from this process, the design cache, or
    solved (then checked and saved). A cached answer that fails ``check`` is solved again."""
    from mwip.cache import digest, load_arrays, save_arrays

    name = digest([_prefix(), kind, *inputs])
    if name in _MEMO:
        return _MEMO[name].copy()
    z = load_arrays("numerics", name)
    if z is not None and "x" in z:
        X = np.asarray(z["x"], dtype=float)
        try:
            check(X)
        except NumericsError:
            pass
        else:
            _MEMO[name] = X
            return X.copy()
    X = np.asarray(solve(), dtype=float)
    check(X)
    _MEMO[name] = X
    save_arrays("numerics", name, {"x": X})
    return X.copy()


def _scipy_failure(what: str, error: type[NumericsError], exc: Exception) -> NumericsError:
    return error(f"{what}: SciPy failed ({str(exc).splitlines()[0] if str(exc) else exc!r})")


# ---------------------------------------------------------------------------------------------
# Solvers
# ---------------------------------------------------------------------------------------------
def solve_continuous_are(a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike) -> Array:
    """The stabilising solution ``X`` of the CARE ``A^T X + X A - X G X + Q = 0``,
    ``G = B R^{-1} B^T`` (``scipy.linalg.solve_continuous_are``), checked and cached.

    Raises :class:`RiccatiError` when SciPy fails, the relative residual exceeds
    :data:`RTOL` or ``A - G X`` is not Hurwitz; ``ValueError`` for bad shapes.
    """
    A, B, Q, R = _riccati_operands(a, b, q, r)

    def solve() -> Array:
        import scipy.linalg as sla

        try:
            return sla.solve_continuous_are(A, B, Q, R)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise _scipy_failure("continuous Riccati equation", RiccatiError, exc) from None

    return _cached("care", (A, B, Q, R), solve, lambda X: _check_care(A, B, Q, R, X))


def solve_discrete_are(a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike) -> Array:
    """The stabilising solution ``X`` of the DARE
    ``A^T X A - X - A^T X B (R + B^T X B)^{-1} B^T X A + Q = 0``
    (``scipy.linalg.solve_discrete_are``), checked and cached.

    Raises :class:`RiccatiError` when SciPy fails, the relative residual exceeds
    :data:`RTOL` or the closed loop is not Schur stable; ``ValueError`` for bad shapes.
    """
    A, B, Q, R = _riccati_operands(a, b, q, r)

    def solve() -> Array:
        import scipy.linalg as sla

        try:
            return sla.solve_discrete_are(A, B, Q, R)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise _scipy_failure("discrete Riccati equation", RiccatiError, exc) from None

    return _cached("dare", (A, B, Q, R), solve, lambda X: _check_dare(A, B, Q, R, X))


def solve_continuous_lyapunov(a: ArrayLike, q: ArrayLike) -> Array:
    """``X`` with ``A X + X A^T = Q`` (``scipy.linalg.solve_continuous_lyapunov``), checked
    and cached. Raises :class:`LyapunovError` when two eigenvalues of ``A`` sum to zero (no
    unique solution), SciPy fails, or the relative residual exceeds :data:`RTOL`."""
    A, Q = _square("a", a), _square("q", q)
    if Q.shape != A.shape:
        raise ValueError(f"q must have a's shape {A.shape}, got {Q.shape}")

    def solve() -> Array:
        import scipy.linalg as sla

        _check_unique(A)
        try:
            return sla.solve_continuous_lyapunov(A, Q)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise _scipy_failure("Lyapunov equation", LyapunovError, exc) from None

    return _cached("lyapunov", (A, Q), solve, lambda X: _check_lyapunov(A, Q, X))


def expm(m: ArrayLike) -> Array:
    """The matrix exponential ``e^M`` (``scipy.linalg.expm``), checked and cached. Raises
    :class:`MatrixExponentialError` when it is not finite or does not commute with ``M``."""
    M = _square("m", m)

    def solve() -> Array:
        import scipy.linalg as sla

        return sla.expm(M)

    return _cached("expm", (M,), solve, lambda E: _check_expm(M, E))
