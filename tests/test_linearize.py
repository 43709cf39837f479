from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip import linearize
from mwip.models import reduced
from mwip.params import NOMINAL, REAL


def _f(p, x, u):
    """Nonlinear right-hand side in the LQR state [theta, alpha, theta', v, alpha']."""
    q = np.array([0.0, x[0], x[1]])
    qd = np.array([x[3] / p.r, x[2], x[4]])
    a = reduced.accelerations(p, q, qd, u)
    return np.array([x[2], x[4], a[1], p.r * a[0], a[2]])


@pytest.mark.parametrize("p", [REAL, NOMINAL], ids=["real", "nominal"])
def test_linearisation_equals_finite_differences(p):
    A, B = linearize(p)
    h = 1e-6
    x0, u0 = np.zeros(5), np.zeros(2)
    Afd = np.column_stack(
        [(_f(p, x0 + h * e, u0) - _f(p, x0 - h * e, u0)) / (2 * h) for e in np.eye(5)]
    )
    Bfd = np.column_stack(
        [(_f(p, x0, u0 + h * e) - _f(p, x0, u0 - h * e)) / (2 * h) for e in np.eye(2)]
    )
    np.testing.assert_allclose(A, Afd, rtol=1e-6, atol=1e-6 * np.abs(A).max())
    np.testing.assert_allclose(B, Bfd, rtol=1e-6, atol=1e-8)


def test_one_unstable_mode_and_its_value():
    eig = np.linalg.eigvals(linearize(REAL)[0])
    unstable = eig[eig.real > 1e-9]
    assert unstable.size == 1
    assert unstable[0].real == pytest.approx(2.396337, rel=1e-5)  # SPEC: about +2.4 rad/s
    # fast damping modes (SPEC section 2): near -3000 (real), -3600 and -3800 (nominal)
    assert sorted(eig.real)[:2] == pytest.approx([-3067.97, -3008.40], rel=1e-4)
    eig_n = np.sort(np.linalg.eigvals(linearize(NOMINAL)[0]).real)
    assert eig_n[:2] == pytest.approx([-3770.8, -3570.6], rel=1e-4)


def test_unstable_mode_closed_form_without_damping():
    """Without damping the pitch/wheel pair has lambda^2 = Gb m11 / (m11 m22 - m12^2)."""
    p = replace(REAL, Db=0.0, Dw=0.0)
    lam = np.sqrt(p.Gb * p.m11 / (p.m11 * p.m22 - p.m12**2))
    eig = np.linalg.eigvals(linearize(p)[0])
    assert eig.real.max() == pytest.approx(lam, rel=1e-10)


def test_batched_linearisation():
    from mwip.params import stack_params

    A, B = linearize(stack_params([REAL, NOMINAL]))
    assert A.shape == (2, 5, 5) and B.shape == (2, 5, 2)
    np.testing.assert_allclose(A[1], linearize(NOMINAL)[0])
