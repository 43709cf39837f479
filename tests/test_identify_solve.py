"""Variable projection (mwip.identify.solve) on a separable problem with a known answer.

Segment ``s`` observes ``y_s(t) = a_s exp(-k t) + b_s cos(w t)`` with globals ``(k, w)``
shared by all segments and nuisances ``(a_s, b_s)`` of its own. The nuisances enter
linearly, so for given globals their minimisers are a linear least-squares solution (an
independent oracle), and on noise-free data the reduced problem's minimum is the truth with
zero residual, where Kaufman's projected Jacobian equals the reduced residual's derivative."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from mwip.identify.solve import Reduced, nuisance_solve, project_out

T = np.linspace(0.0, 2.0, 25)
LO, HI = np.array([0.2, 1.0]), np.array([3.0, 6.0])  # the globals' ranges, scaled to [0, 1]
TRUTH = np.array([1.3, 3.7])
rng = np.random.default_rng(4)
S = 9
AB = np.column_stack([rng.uniform(0.5, 2.0, S), rng.uniform(-1.5, 1.5, S)])


def basis(g: np.ndarray) -> np.ndarray:
    """(B, n, 2) the model's two columns for globals ``g`` (B, 2) in physical units."""
    return np.stack([np.exp(-g[:, :1] * T), np.cos(g[:, 1:] * T)], axis=2)


Y = np.einsum("snk,sk->sn", basis(np.tile(TRUTH, (S, 1))), AB)


def residual(x: np.ndarray, z: np.ndarray, idx: np.ndarray) -> np.ndarray:
    g = LO + np.atleast_2d(x) * (HI - LO)
    g = np.broadcast_to(g, (len(idx), 2))
    return np.einsum("snk,sk->sn", basis(g), z) - Y[idx]


def test_the_nuisance_solve_is_the_linear_least_squares_solution() -> None:
    x = np.array([0.3, 0.55])
    z, r, Jn = nuisance_solve(residual, x, np.zeros((S, 2)))
    G = basis(np.tile(LO + x * (HI - LO), (S, 1)))
    for s in range(S):
        exact = np.linalg.lstsq(G[s], Y[s], rcond=None)[0]
        np.testing.assert_allclose(z[s], exact, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(r, residual(x, z, np.arange(S)), atol=1e-12)
    np.testing.assert_allclose(Jn, G, rtol=1e-5, atol=1e-6)  # d r / d z is the model's basis


def test_projection_removes_the_nuisance_directions() -> None:
    Jn = rng.standard_normal((4, 25, 2))
    A = rng.standard_normal((4, 25, 3))
    P = project_out(Jn, A)
    assert np.abs(Jn.transpose(0, 2, 1) @ P).max() < 1e-12
    np.testing.assert_allclose(project_out(Jn, P), P, atol=1e-12)  # a projection


def test_reduced_problem_recovers_the_truth_and_its_jacobian_is_the_derivative() -> None:
    red = Reduced(residual, np.zeros((S, 2)))
    sol = least_squares(red.fun, np.array([0.5, 0.5]), jac=red.jac, bounds=(0.0, 1.0),
                        method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    found = LO + sol.x * (HI - LO)
    np.testing.assert_allclose(found, TRUTH, rtol=1e-7)
    z, r, _ = red.state(sol.x)
    np.testing.assert_allclose(z, AB, rtol=1e-6, atol=1e-8)
    assert np.sqrt(np.mean(r**2)) < 1e-9
    # zero residual: Kaufman's Jacobian is d rho / d x (central differences of rho)
    x0 = (TRUTH - LO) / (HI - LO)
    J = red.jac(x0)
    h = 1e-6
    num = np.column_stack([(Reduced(residual, AB.copy()).fun(x0 + h * e)
                            - Reduced(residual, AB.copy()).fun(x0 - h * e)) / (2 * h)
                           for e in np.eye(2)])  # fmt: skip
    assert J == pytest.approx(num, rel=1e-3, abs=1e-5)
