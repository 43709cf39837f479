from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip import linearize
from mwip.models import reduced
from mwip.params import NOMINAL, NOMINAL_LITERAL, REAL, REAL_LITERAL


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


def _independent_poles(p):
    """Open-loop poles from the linearised (2.32) written out by hand: the (psi, theta) pair
    ``det(M0 s^2 + D s + K) / s = 0`` (psi itself is not in the state) with
    ``M0 = [[m11, m12], [m12, m22]]``, ``D = [[2(Dw+Db), -2Db], [-2Db, 2Db]]``,
    ``K = [[0, 0], [0, -Gb]]``, plus yaw ``0`` and ``-(2 b^2/r^2)(Db + Dw) / m33``."""
    P = np.polynomial.polynomial
    a11 = [0.0, 2 * (p.Dw + p.Db), p.m11]  # coefficients of s^0, s^1, s^2
    a12 = [0.0, -2 * p.Db, p.m12]
    a22 = [-p.Gb, 2 * p.Db, p.m22]
    det = P.polysub(P.polymul(a11, a22), P.polymul(a12, a12))
    pair = P.polyroots(det[1:])  # divide by s
    yaw = -(2 * p.b**2 / p.r**2) * (p.Db + p.Dw) / p.m33
    return np.sort(np.concatenate([pair.real, [0.0, yaw]]))


@pytest.mark.parametrize(
    "p", [REAL, NOMINAL, REAL_LITERAL, NOMINAL_LITERAL],
    ids=["real", "nominal", "real-literal", "nominal-literal"],
)  # fmt: skip
def test_poles_match_an_independent_derivation(p):
    eig = np.sort(np.linalg.eigvals(linearize(p)[0]).real)
    np.testing.assert_allclose(eig, _independent_poles(p), rtol=1e-9, atol=1e-9)
    assert np.sum(eig > 1e-9) == 1  # one unstable (pitch) mode


def test_poles_as_spec_states_them():
    """SPEC section 2: units reading about -24, -4.9, -0.85, 0, +20.1 (real parameters), not
    stiff; the literal reading adds damping modes near -3000 and slows pitch to +2.4."""
    eig = np.sort(np.linalg.eigvals(linearize(REAL)[0]).real)
    assert eig == pytest.approx([-24.1, -4.91, -0.851, 0.0, 20.1], rel=0.01, abs=1e-9)
    lit = np.sort(np.linalg.eigvals(linearize(REAL_LITERAL)[0]).real)
    assert lit[:2] == pytest.approx([-3068, -3008], rel=1e-3)
    assert lit[-1] == pytest.approx(2.396, rel=1e-3)


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


def test_package_attribute_is_the_function_after_importing_a_models_module():
    """Issue 24: ``import mwip; from mwip.models import reduced; mwip.linearize(...)`` used to
    raise ``TypeError: 'module' object is not callable`` (module and function of one name);
    the module is ``mwip.models.linear`` now, in a fresh process."""
    import subprocess
    import sys

    code = ("import mwip; from mwip.models import reduced; from mwip import params; "
            "import mwip.models.linear; A, B = mwip.linearize(params.NOMINAL); "
            "print(A.shape, B.shape, callable(mwip.linearize))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()  # fmt: skip
    assert out == ["(5,", "5)", "(5,", "2)", "True"]
