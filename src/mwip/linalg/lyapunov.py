"""Lyapunov and Stein equations of small size by their Kronecker (vec) form.

Continuous: ``A X + X A^H = Q`` (SciPy's ``solve_continuous_lyapunov`` convention). With the
row-major stacking ``vec(X)`` of NumPy, ``vec(A X B) = (A (x) B^T) vec(X)``, so

.. math::

    (A \\otimes I + I \\otimes \\bar A)\\, \\mathrm{vec}(X) = \\mathrm{vec}(Q),

a linear system of size ``n^2`` whose matrix has eigenvalues ``lambda_i + conj(lambda_j)``:
solvable uniquely iff no two eigenvalues of ``A`` satisfy ``lambda_i + conj(lambda_j) = 0``.

Discrete (Stein): ``A X A^H - X + Q = 0`` (``solve_discrete_lyapunov``), i.e.
``(A (x) conj(A) - I) vec(X) = -vec(Q)``, unique iff no ``lambda_i conj(lambda_j) = 1``.

Solved by LU with partial pivoting, ``O(n^6)`` work: meant for ``n <= 40`` (the observer's
error dynamics have ``n = 3 x order <= 15``); Bartels-Stewart (the Schur method SciPy uses)
would need a Schur decomposition that NumPy does not offer.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.linalg._check import square

__all__ = ["solve_continuous_lyapunov", "solve_discrete_lyapunov", "MAX_ORDER"]

#: Largest order accepted (the Kronecker system has MAX_ORDER^2 unknowns).
MAX_ORDER = 40

_EPS = float(np.finfo(float).eps)


def _operands(a: ArrayLike, q: ArrayLike) -> tuple[NDArray, NDArray]:
    A, Q = square("a", a), square("q", q)
    if Q.shape != A.shape:
        raise ValueError(f"q must have the shape of a, {A.shape}, got {Q.shape}")
    if A.shape[0] > MAX_ORDER:
        raise ValueError(f"a must be at most {MAX_ORDER}x{MAX_ORDER} (Kronecker form), "
                         f"got {A.shape}")  # fmt: skip
    return A, Q


def _solve(kron: NDArray, rhs: NDArray, n: int, what: str) -> NDArray:
    try:
        x = np.linalg.solve(kron, rhs.reshape(-1))
    except np.linalg.LinAlgError:
        raise ValueError(f"{what} has no unique solution (singular operator)") from None
    return x.reshape(n, n)


def solve_continuous_lyapunov(a: ArrayLike, q: ArrayLike) -> NDArray:
    """``X`` with ``A X + X A^H = Q`` (module docstring; SciPy's argument order and meaning).

    Raises ``ValueError`` when the solution is not unique: ``A`` has eigenvalues with
    ``lambda_i + conj(lambda_j) = 0`` (to ``100 n eps ||A||_1``), e.g. on the imaginary axis.
    """
    A, Q = _operands(a, q)
    n = A.shape[0]
    lam = np.linalg.eigvals(A) if n else np.zeros(0)
    scale = max(float(np.abs(A).sum(axis=0).max()) if n else 0.0, np.finfo(float).tiny)
    if n and np.min(np.abs(lam[:, None] + lam.conj()[None, :])) <= 100 * n * _EPS * scale:
        raise ValueError("a has eigenvalues with lambda_i + conj(lambda_j) = 0: the Lyapunov "
                         "equation A X + X A^H = Q has no unique solution")  # fmt: skip
    eye = np.eye(n)
    kron = np.kron(A, eye) + np.kron(eye, A.conj())
    dtype = np.result_type(A, Q)
    return _solve(kron.astype(dtype), Q.astype(dtype), n, "the Lyapunov equation")


def solve_discrete_lyapunov(a: ArrayLike, q: ArrayLike) -> NDArray:
    """``X`` with ``A X A^H - X + Q = 0`` (module docstring; SciPy's convention).

    Raises ``ValueError`` when the solution is not unique: ``lambda_i conj(lambda_j) = 1`` for
    eigenvalues of ``A`` (to ``100 n eps max(1, ||A||_1^2)``).
    """
    A, Q = _operands(a, q)
    n = A.shape[0]
    lam = np.linalg.eigvals(A) if n else np.zeros(0)
    scale = max(1.0, float(np.abs(A).sum(axis=0).max()) ** 2 if n else 0.0)
    if n and np.min(np.abs(lam[:, None] * lam.conj()[None, :] - 1.0)) <= 100 * n * _EPS * scale:
        raise ValueError("a has eigenvalues with lambda_i conj(lambda_j) = 1: the Stein "
                         "equation A X A^H - X + Q = 0 has no unique solution")  # fmt: skip
    kron = np.kron(A, A.conj()) - np.eye(n * n)
    dtype = np.result_type(A, Q)
    return _solve(kron.astype(dtype), -Q.astype(dtype), n, "the Stein equation")
