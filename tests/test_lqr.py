from __future__ import annotations

import numpy as np
import pytest

from mwip import linearize
from mwip.laws.lqr.controller import BOOK_Q, BOOK_R, design_lqr, dlqr, lqr, lqr_sampled, zoh
from mwip.params import NOMINAL, NOMINAL_LITERAL, REAL, REAL_LITERAL


def test_scalar_lqr_closed_form():
    # x' = u, cost q x^2 + r u^2: K = sqrt(q / r)
    K, P, E = lqr([[0.0]], [[1.0]], [[4.0]], [[0.25]])
    assert K[0, 0] == pytest.approx(4.0) and E[0] == pytest.approx(-4.0)


def test_book_gain_independent_check():
    """SPEC section 3: rows [-223.99, +-70.71, -70.32, -23.12, +-218.99] on the nominal
    parameters, an independent computation made under the literal damping reading."""
    d = design_lqr(NOMINAL_LITERAL, Ts=None)
    np.testing.assert_allclose(d.K[0], [-223.99, 70.71, -70.32, -23.12, 218.99], atol=0.006)
    np.testing.assert_allclose(d.K[1], [-223.99, -70.71, -70.32, -23.12, -218.99], atol=0.006)
    # the yaw entries match the book's printed 70.71 and 219.80 (to 0.4 %)
    assert abs(d.K[0, 1]) == pytest.approx(70.71, rel=1e-3)
    assert abs(d.K[0, 4]) == pytest.approx(219.80, rel=5e-3)


@pytest.mark.parametrize("p", [NOMINAL, NOMINAL_LITERAL])
def test_yaw_angle_gain_is_analytic(p):
    """The yaw channel is a double integrator with damping; for the yaw angle the Riccati
    solution gives the gain sqrt(Q_alpha / (2 R)) = sqrt(100 / 0.02) = 70.7107 per wheel
    whatever the inertia and damping (the wheels act with opposite signs)."""
    K = design_lqr(p, Ts=None).K
    assert K[0, 1] == pytest.approx(np.sqrt(100.0 / 0.02), rel=1e-9)
    assert K[1, 1] == pytest.approx(-np.sqrt(100.0 / 0.02), rel=1e-9)


def test_book_gain_on_real_plant_poles():
    """SPEC section 2: nominal design on the real plant, literal reading: about -1.4e5,
    -1.0e5, -142, -3.2, -0.32; the units reading keeps the poles near -1e5 rad/s."""
    K = design_lqr(NOMINAL_LITERAL, Ts=None).K
    A, B = linearize(REAL_LITERAL)
    poles = np.sort(np.linalg.eigvals(A - B @ K).real)
    np.testing.assert_allclose(poles, [-1.4088e5, -1.0075e5, -141.8, -3.158, -0.3159], rtol=2e-3)
    K = design_lqr(NOMINAL, Ts=None).K
    A, B = linearize(REAL)
    poles = np.sort(np.linalg.eigvals(A - B @ K).real)
    assert poles[0] < -5e4 and poles[1] < -5e4 and np.all(poles < 0)


def test_book_gain_with_5ms_hold_is_violently_unstable():
    K = design_lqr(NOMINAL_LITERAL, Ts=None).K
    Ad, Bd = zoh(*linearize(REAL_LITERAL), 0.005)
    rho = np.abs(np.linalg.eigvals(Ad - Bd @ K)).max()
    assert 40 < rho < 60  # SPEC: about 48 (literal reading)
    K = design_lqr(NOMINAL, Ts=None).K
    Ad, Bd = zoh(*linearize(REAL), 0.005)
    assert np.abs(np.linalg.eigvals(Ad - Bd @ K)).max() > 10  # units reading: still unstable


def test_sampled_design_is_stable_on_both_parameter_sets():
    d = design_lqr(NOMINAL, Ts=0.005)
    assert np.abs(d.poles).max() < 1
    Ad, Bd = zoh(*linearize(REAL), 0.005)
    assert np.abs(np.linalg.eigvals(Ad - Bd @ d.K)).max() < 1


def test_zoh_matches_integral():
    A, B = linearize(NOMINAL)
    Ad, Bd = zoh(A, B, 0.005)
    from scipy.integrate import quad_vec
    from scipy.linalg import expm

    Bq = quad_vec(lambda s: expm(A * s) @ B, 0, 0.005)[0]
    np.testing.assert_allclose(Ad, expm(A * 0.005), rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(Bd, Bq, rtol=1e-6, atol=1e-12)


def test_dlqr_riccati_residual():
    A, B = linearize(NOMINAL)
    K, P, _ = lqr_sampled(A, B, BOOK_Q, BOOK_R, 0.005)
    Ad, Bd = zoh(A, B, 0.005)
    res = Ad.T @ P @ Ad - P - Ad.T @ P @ Bd @ K + BOOK_Q
    assert np.abs(res).max() < 1e-6 * np.abs(P).max()


def test_bad_weights():
    A, B = linearize(NOMINAL)
    with pytest.raises(ValueError, match="R must be"):
        lqr(A, B, BOOK_Q, -BOOK_R)
    with pytest.raises(ValueError, match="Ts must be"):
        lqr_sampled(A, B, BOOK_Q, BOOK_R, 0.0)


def test_old_dlqr_form_says_what_to_call():
    """dlqr(A, B, Q, R, Ts) on continuous matrices was the old form: now a TypeError naming
    lqr_sampled; the sampled design is dlqr on the ZOH model, bit for bit."""
    A, B = linearize(NOMINAL)
    for Ts in (0.005, 1):
        with pytest.raises(TypeError, match=r"lqr_sampled\(A, B, Q, R, Ts\)"):
            dlqr(A, B, BOOK_Q, BOOK_R, Ts)
    K, S, E = lqr_sampled(A, B, BOOK_Q, BOOK_R, 0.005)
    K2, S2, E2 = dlqr(*zoh(A, B, 0.005), BOOK_Q, BOOK_R)
    assert np.array_equal(K, K2) and np.array_equal(S, S2) and np.array_equal(E, E2)
    assert np.array_equal(design_lqr(NOMINAL, Ts=0.005).K, K)
    assert np.all(np.abs(E) < 1)
