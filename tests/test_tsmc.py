"""Terminal SMC (Section 4.3): cubic augmenting functions, surfaces, law, closed loop."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import random_states
from mwip.laws.switching import Switching
from mwip.laws.tsmc.controller import (
    TSMC,
    cubic_coefficients,
    lean_for_speed,
)  # fmt: skip
from mwip.models.reduced import accelerations
from mwip.params import NOMINAL, REAL, book_params, steady_speed_cap
from mwip.sim import simulate
from mwip.sim.sensors import Measurement
from oracle_laws import augmenting, model_2_31, subsystem, tsmc_gain, tsmc_surface


def test_cubic_boundary_conditions():
    e0, ed0, Tf = np.array([0.1, -0.5]), np.array([0.3, 2.0]), 1.3
    c = cubic_coefficients(e0, ed0, Tf)
    a, ad, _ = augmenting(0.0, c, Tf)
    np.testing.assert_allclose(a, e0)
    np.testing.assert_allclose(ad, ed0)
    a, ad, _ = augmenting(Tf, c, Tf)
    np.testing.assert_allclose(a, 0.0, atol=1e-12)
    np.testing.assert_allclose(ad, 0.0, atol=1e-12)
    assert all(np.all(x == 0) for x in augmenting(Tf + 0.01, c, Tf))
    # derivatives are consistent (finite differences)
    h = 1e-6
    ap, adp, _ = augmenting(0.4 + h, c, Tf)
    am, adm, _ = augmenting(0.4 - h, c, Tf)
    _, ad, add = augmenting(0.4, c, Tf)
    np.testing.assert_allclose((ap - am) / (2 * h), ad, rtol=1e-6)
    np.testing.assert_allclose((adp - adm) / (2 * h), add, rtol=1e-6)
    with pytest.raises(ValueError):
        cubic_coefficients(e0, ed0, 0.0)


def test_model_2_31_matches_reduced_model(rng):
    q, qd, u, _ = random_states(rng, 32)
    F, G = model_2_31(NOMINAL, q, qd)
    xdot = F + np.einsum("nij,nj->ni", G, u)
    acc = accelerations(NOMINAL, q, qd, u)
    np.testing.assert_allclose(xdot[:, 0], acc[:, 1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(xdot[:, 1], NOMINAL.r * acc[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(xdot[:, 2], acc[:, 2], rtol=1e-9, atol=1e-9)
    F1, G1 = subsystem(NOMINAL, q, qd)
    assert F1.shape == (32, 2) and G1.shape == (32, 2, 2)
    assert np.all(np.abs(np.linalg.det(G1)) > 0)


def test_surface_zero_at_start_and_law_gives_reaching_dynamics(rng):
    """s(0) = 0 by construction; on the nominal model s' = -k sat(s/phi) exactly."""
    n = 16
    q, qd, _, _ = random_states(rng, n)
    q[:, 1] *= 0.3
    y = np.column_stack([q, qd, np.zeros((n, 2))])
    ctrl = TSMC(NOMINAL, switching=Switching("sat", 0.05), alpha_dot_ref=0.2)
    ctrl.reset(Measurement(0.0, y))
    ctrl(0.0, Measurement(0.0, y))
    np.testing.assert_allclose(ctrl.log()["s"], 0.0, atol=1e-12)
    # a later time, perturbed state: check s' on the nominal model
    t = 0.3
    y2 = y.copy()
    y2[:, 3:6] += rng.normal(0, 0.2, (n, 3))
    u = ctrl(t, Measurement(t, y2))
    s, k = ctrl.log()["s"], ctrl.log()["k"]
    acc = accelerations(NOMINAL, y2[:, :3], y2[:, 3:6], u)
    C = ctrl.C
    _, ad, add = augmenting(t, ctrl._coeffs, ctrl.Tf)
    s_dot = acc[:, [1, 2]] + C * (y2[:, [4, 5]] - [0.0, 0.2]) - add - C * ad
    np.testing.assert_allclose(s_dot, -k * np.clip(s / 0.05, -1, 1), rtol=1e-7, atol=1e-7)


def test_gain_formula():
    F1 = np.array([[2.0, -1.0]])
    term = np.array([[-3.0, 4.0]])
    k = tsmc_gain(F1, term, 0.8, 0.4 * np.eye(2), [10.0, 5.0])
    np.testing.assert_allclose(k, [[(1.6 + 1.2 + 10) / 0.6, (0.8 + 1.6 + 5) / 0.6]])
    s = tsmc_surface([0.1, 0.2], [0.0, 1.0], [0.05, 0.0], [0.0, 0.5], [2.0, 3.0])
    np.testing.assert_allclose(s, [0.1, 1.1])


def test_invalid_parameters():
    with pytest.raises(ValueError):
        TSMC(D=1.0)
    with pytest.raises(ValueError):
        TSMC(C=(0.0, 1.0))
    with pytest.raises(ValueError):
        TSMC(speed="fast")  # type: ignore[arg-type]


def test_lean_for_speed():
    """Steady rolling: 2 Dw psi' = Gb sin(theta) (no yaw); about 0.041 rad for 1 m/s on the
    real plant under the units reading (SPEC.md section 3); none above the speed cap."""
    th = lean_for_speed(REAL, 1.0)
    assert 2 * REAL.Dw * (1.0 / REAL.r) == pytest.approx(REAL.Gb * np.sin(th), rel=1e-12)
    assert 0.040 < th < 0.042
    cap = REAL.r * steady_speed_cap(REAL)  # m/s, reached lying flat
    assert np.isnan(lean_for_speed(REAL, 1.01 * cap)) and lean_for_speed(REAL, 0.99 * cap) < 1.6
    # the literal reading caps the speed at 4 cm/s: 1 m/s is impossible there
    assert np.isnan(lean_for_speed(book_params("real", "literal"), 1.0))
    # with a yaw rate the centrifugal term adds to gravity: a smaller lean
    assert 0 < lean_for_speed(REAL, 0.2, 0.2) < lean_for_speed(REAL, 0.2)
    lean = TSMC(NOMINAL, v_ref=1.0, speed="lean")
    assert lean.theta_ref == pytest.approx(lean_for_speed(NOMINAL, 1.0), rel=1e-12)
    assert TSMC(NOMINAL, v_ref=1.0, speed="lean", theta_max=0.01).theta_ref == 0.01


def test_targets_reached_by_Tf_on_nominal_plant():
    """With s(0) = 0 and sliding from the start, e = a(t): theta, alpha at target by T_f."""
    ctrl = TSMC(NOMINAL, Tf=1.0, switching=Switching("sat", 0.05))
    res = simulate(ctrl, NOMINAL, q0=(0, 0.1, 0.5), qdot0=(0.5 / NOMINAL.r, 0.0, 0.0),
                   duration=1.5, Ts=0.005, dt=0.001, mode="continuous")  # fmt: skip
    assert res.ok
    i = int(np.searchsorted(res.t, 1.0))
    assert abs(res.alpha[0]) == 0.5 and abs(res.theta[i]) < 1e-4 and abs(res.alpha[i]) < 1e-3
    assert np.max(np.abs(res.theta[i:])) < 1e-4
    # the trajectory follows the cubic before T_f: theta(0.5) = a_1(0.5)
    j = int(np.searchsorted(res.t, 0.5))
    a, _, _ = augmenting(0.5, cubic_coefficients([0.1, 0.5], [0.0, 0.0], 1.0), 1.0)
    np.testing.assert_allclose([res.theta[j], res.alpha[j]], a, atol=2e-3)
