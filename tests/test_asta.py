"""Adaptive super-twisting (Section 4.2): constraints, laws, adaptive law, sliding accuracy."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import random_states
from mwip.laws.asta.controller import (
    ASMC,
    ASTA,
    adaptive_rate,
    asmc_law,
    asta_law,
    asta_surface,
    check_constraints,
    sliding_jacobian,
    sta_term,
)  # fmt: skip
from mwip.models.reduced import accelerations
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate
from mwip.sim.sensors import Measurement
from oracle_laws import surface_dynamics

BOOK_LAM = (10.0, 0.3, 0.3)


def test_constraints_and_sliding_jacobian():
    assert check_constraints(NOMINAL, BOOK_LAM) and check_constraints(REAL, BOOK_LAM)
    assert not check_constraints(NOMINAL, (10.0, 1.0, 0.3))  # lambda_2 z2* - z1* > 0
    assert not check_constraints(NOMINAL, (-1.0, 0.3, 0.3))
    A = sliding_jacobian(NOMINAL, BOOK_LAM)
    assert A[1, 0] < 0 and A[1, 1] < 0  # (4.23)
    assert np.all(np.linalg.eigvals(A).real < 0)
    assert np.any(np.linalg.eigvals(sliding_jacobian(NOMINAL, (10.0, 1.0, 0.3))).real > 0)
    with pytest.raises(ValueError):
        ASTA(lam=(10.0, 1.0, 0.3))


def test_surface_dynamics_match_model(rng):
    """sigma' = a + b [u_A, u_B] (4.10)-(4.11) on the nominal model."""
    q, qd, u, _ = random_states(rng, 32)
    q[:, 1] *= 0.5
    a, b = surface_dynamics(NOMINAL, q, qd, BOOK_LAM)
    acc = accelerations(NOMINAL, q, qd, u)
    l1, l2, l3 = BOOK_LAM
    sd = np.column_stack([acc[:, 1] + l1 * qd[:, 1] + l2 * acc[:, 0], acc[:, 2] + l3 * qd[:, 2]])
    uab = np.column_stack([u[:, 0] + u[:, 1], u[:, 0] - u[:, 1]])
    np.testing.assert_allclose(sd, a + b * uab, rtol=1e-9, atol=1e-9)
    s = asta_surface(q, qd, BOOK_LAM, (0.5, 0.0, 0.1, 0.0))
    np.testing.assert_allclose(s[:, 0], qd[:, 1] + l1 * q[:, 1] + l2 * (qd[:, 0] - 0.5))
    np.testing.assert_allclose(s[:, 1], qd[:, 2] + l3 * (q[:, 2] - 0.1))


def test_laws_realise_sta_and_asmc(rng):
    q, qd, _, _ = random_states(rng, 8)
    q[:, 1] *= 0.5
    a, b = surface_dynamics(NOMINAL, q, qd, BOOK_LAM)
    s = asta_surface(q, qd, BOOK_LAM)
    K, w, G = np.array([10.0, 0.3]), rng.normal(size=(8, 2)), np.array([5.0, 2.0])
    for law, expect in ((asta_law(a, b, s, K, w), sta_term(s, K) + w),
                        (asmc_law(a, b, s, K, G), sta_term(s, K) - G * np.sign(s))):  # fmt: skip
        acc = accelerations(NOMINAL, q, qd, law)
        l1, l2, l3 = BOOK_LAM
        sd = np.column_stack(
            [acc[:, 1] + l1 * qd[:, 1] + l2 * acc[:, 0], acc[:, 2] + l3 * qd[:, 2]]
        )
        np.testing.assert_allclose(sd, expect, rtol=1e-8, atol=1e-8)


def test_adaptive_law_boundary_layer():
    r = adaptive_rate([[0.5, -0.005], [-0.02, 0.0]], [5.0, 2.0], 0.01)
    np.testing.assert_allclose(r, [[2.5, 0.0], [0.1, 0.0]])
    ctrl = ASTA(Ts=0.001, rate=(5.0, 5.0), Gamma0=(1.0, 2.0), eps=0.01)
    y = np.zeros((2, 8))
    y[0, 1] = 0.1  # sigma_1 = 1 -> grows by 5 * 1 * Ts
    ctrl.reset(Measurement(0.0, y))
    ctrl(0.0, Measurement(0.0, y))
    np.testing.assert_allclose(ctrl.Gamma, [[1.005, 2.0], [1.0, 2.0]])


def _discrete_band(kind: str, Ts: float, duration: float = 6.0, sub: int = 8) -> float:
    """Sampled sliding dynamics sigma' = v_k + d(t) (v held over Ts) with a Lipschitz
    disturbance; returns max |sigma| over the second half (the accuracy band)."""
    K, G = 1.5, 2.0
    s, w = 0.5, 0.0
    h = Ts / sub
    band = 0.0
    for k in range(int(round(duration / Ts))):
        t = k * Ts
        v = sta_term(s, K) + (w if kind == "asta" else -G * np.sign(s))
        w -= Ts * G * np.sign(s)
        for j in range(sub):  # the disturbance integrated finely within the sample
            s += h * (v + 0.8 * np.sin(1.3 * (t + (j + 0.5) * h)))
        if t > duration / 2:
            band = max(band, abs(float(s)))
    return band


def test_sigma_band_scales_with_Ts_squared_for_sta_and_Ts_for_smc():
    """Halving Ts shrinks the STA's band ~4x (Ts^2), the first-order SMC's only ~2x (Ts)."""
    r_sta = _discrete_band("asta", 2e-3) / _discrete_band("asta", 1e-3)
    r_smc = _discrete_band("asmc", 2e-3) / _discrete_band("asmc", 1e-3)
    assert 3.0 < r_sta < 5.5, r_sta
    assert 1.5 < r_smc < 2.7, r_smc


def test_closed_loop_second_order_sliding_and_gains_stop():
    """Nominal plant: ASTA reaches sigma = sigma' = 0, ASMC's sigma' keeps chattering;
    the adaptive gains stop growing once |sigma| < eps."""
    out = {}
    for cls in (ASTA, ASMC):
        res = simulate(cls(NOMINAL, Ts=0.001), NOMINAL, q0=(0.0, -np.pi / 18, 0.0),
                       duration=2.0, Ts=0.001, dt=0.001)  # fmt: skip
        assert res.ok
        acc = accelerations(NOMINAL, res.q, res.q_dot, res.u)
        sd = acc[:, 1] + 10.0 * res.q_dot[:, 1] + 0.3 * acc[:, 0]
        s = res.series()["sigma"][:, 0]
        g = res.series()["Gamma"][:, 0]
        tail = res.t > 1.0
        out[cls.__name__] = (np.abs(s[tail]).max(), np.abs(sd[tail]).max())
        assert np.all(np.abs(s[tail]) < 0.01)
        assert g[tail][-1] == g[tail][0] > 0  # frozen inside the boundary layer
        assert np.all(np.diff(g) >= 0)
    assert out["ASTA"][0] < 1e-4 and out["ASTA"][1] < 0.05
    assert out["ASMC"][1] > 10 * out["ASTA"][1]


def test_closed_loop_band_scales_like_the_algorithm_on_the_plant():
    """On the (non-stiff, units-reading) nominal plant the closed-loop sliding band shrinks
    like the abstract sampled dynamics: by ~4 (Ts^2) for ASTA and ~2 (Ts) for ASMC when Ts is
    halved (docs/chapter4.md, "Sliding accuracy")."""
    bands = {}
    for Ts in (0.001, 0.0005):
        for cls in (ASTA, ASMC):
            res = simulate(cls(NOMINAL, Ts=Ts), NOMINAL, q0=(0, -np.pi / 18, 0), duration=3.0,
                           Ts=Ts, dt=Ts)  # fmt: skip
            s = asta_surface(res.q, res.q_dot, (10.0, 0.3, 0.3))
            bands[cls.__name__, Ts] = np.abs(s[res.t > 2.0, 0]).max()
    assert 3.3 < bands["ASTA", 0.001] / bands["ASTA", 0.0005] < 4.7
    assert 1.7 < bands["ASMC", 0.001] / bands["ASMC", 0.0005] < 2.4
    assert bands["ASTA", 0.0005] < 0.1 * bands["ASMC", 0.0005]
