"""IT2 TS model (5.4)-(5.8) and PDC balance design (5.9)-(5.20)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mwip.cli.design import design_it2
from mwip.fuzzy.pdc import (
    PDCBalance,
    PDCInfeasibleError,
    check_design,
    design_pdc,
    pdc_gain,
    verify_design,
)
from mwip.fuzzy.ts_model import (
    first_weight,
    memberships,
    nie_tan_weights,
    nonlinear_rhs,
    quasi_lpv,
    vertex_matrices,
)
from mwip.models.linear import linearize
from mwip.params import NOMINAL, NOMINAL_LITERAL
from mwip.sim import simulate

EPS, RHO = 0.2, 20.0


@pytest.fixture(scope="module")
def design():
    return design_pdc(epsilon=EPS, rho=RHO)


def test_vertex_1_is_the_upright_linearisation():
    ts = vertex_matrices(NOMINAL)
    A5, B5 = linearize(NOMINAL)  # [theta, alpha, theta', v, alpha'], v = r psi'
    r = NOMINAL.r
    np.testing.assert_allclose(ts.A[0, 1], [A5[2, 0], A5[2, 2], 0.0, A5[2, 3] * r], rtol=1e-12)
    np.testing.assert_allclose(ts.A[0, 3], [A5[3, 0] / r, A5[3, 2] / r, 0.0, A5[3, 3]], rtol=1e-12)
    np.testing.assert_allclose(ts.B[0, [1, 3], 0], [B5[2, 0], B5[3, 0] / r], rtol=1e-12)


def test_memberships_of_fig_5_1():
    th = np.linspace(-1.0, 1.0, 401)
    lo, up = memberships(th)
    assert np.all(lo <= up + 1e-15)
    np.testing.assert_allclose(lo[:, 1], 1 - up[:, 0])
    np.testing.assert_allclose(nie_tan_weights(th).sum(-1), 1.0)
    assert nie_tan_weights(0.0)[0] == 1.0 and nie_tan_weights(math.pi / 6)[1] == 1.0
    assert lo[np.argmin(np.abs(th - math.pi / 7)), 0] == pytest.approx(0.0, abs=1e-2)


def test_closed_form_weight_matches_the_nie_tan_reduction():
    """The controllers' fast path ``m_1`` equals (5.8) evaluated from the memberships."""
    th = np.linspace(-1.0, 1.0, 401)
    np.testing.assert_allclose(first_weight(th), nie_tan_weights(th)[:, 0], atol=1e-15)
    G = np.array([[1.0, 2.0, 3.0, 4.0], [-1.0, 0.5, 2.0, 8.0]])
    np.testing.assert_allclose(pdc_gain(G, th), nie_tan_weights(th) @ G, atol=1e-13)


def test_ts_model_approximates_the_pitch_wheel_dynamics():
    """Blended model (5.8) vs the nonlinear (5.3) over theta in [-pi/6, pi/6]."""
    rng = np.random.default_rng(0)
    th = np.linspace(-math.pi / 6, math.pi / 6, 121)
    x = np.stack([th, rng.uniform(-1, 1, th.size), rng.uniform(-5, 5, th.size),
                  rng.uniform(-5, 5, th.size)], -1)  # fmt: skip
    u = rng.uniform(-2, 2, th.size)
    f = nonlinear_rhs(NOMINAL, x, u)
    errs = {}
    for reading in ("sector", "book"):
        g = vertex_matrices(NOMINAL, reading).rhs(x, u)
        errs[reading] = [np.max(np.abs(f[:, k] - g[:, k])) / np.max(np.abs(f[:, k]))
                         for k in (1, 3)]  # fmt: skip
    assert max(errs["sector"]) < 0.12
    assert max(errs["sector"]) < max(errs["book"])  # the sector reading is the closer one
    # exact (without the dropped centripetal term) where one rule fires alone
    xv = np.array([[math.pi / 6, 0.0, 0.3, -0.7], [0.0, 0.0, 0.3, -0.7]])
    np.testing.assert_allclose(vertex_matrices(NOMINAL).rhs(xv, [0.5, 0.5]),
                               nonlinear_rhs(NOMINAL, xv, [0.5, 0.5]), rtol=1e-10)  # fmt: skip
    A, _ = quasi_lpv(NOMINAL, np.array([0.1, -0.1]))
    np.testing.assert_allclose(A[0], A[1])  # even in theta


def test_designed_gains_satisfy_the_lmis_and_vertex_loops_are_hurwitz(design):
    c = check_design(design)
    assert design.status == "optimal"
    assert c["P_min"] > 0 and c["W_min"] > 0
    assert c["lmi_ii"] < 0 and c["lmi_ij"] <= 1e-9
    assert c["eps_ball"] <= 1e-9 and c["input"] <= 1e-9
    K = design.closed_loop()
    for i in range(2):
        for j in range(2):
            assert np.linalg.eigvals(K[i, j]).real.max() < 0


def test_infeasible_bound_raises_one_line():
    with pytest.raises(PDCInfeasibleError) as err:
        design_pdc(epsilon=EPS, rho=0.1)
    assert "\n" not in str(err.value) and "infeasible" in str(err.value)
    with pytest.raises(ValueError):
        design_pdc(epsilon=EPS)


def test_inaccurate_solver_point_is_rejected():
    """At the edge of feasibility Clarabel reports ``optimal_inaccurate`` for a point with a
    positive (5.12) residual and an unstable vertex loop (literal-damping nominal model,
    epsilon 0.2, rho 0.47097); design_pdc used to return it as a design."""
    with pytest.raises(PDCInfeasibleError) as err:
        design_pdc(epsilon=0.2, rho=0.47097, params=NOMINAL_LITERAL)
    msg = str(err.value)
    assert "\n" not in msg and "fails its check" in msg and "optimal_inaccurate" in msg
    assert "lmi_ii" in msg and "vertex loop 1 unstable" in msg


def test_verify_design_catches_bad_points(design):
    """Solver-independent: a verified design passes; spoiling it in any checked way fails."""
    import dataclasses

    verify_design(design)
    spoilt = {
        "vertex loop": dataclasses.replace(design, G=-design.G),  # wrong sign: unstable
        "P_min": dataclasses.replace(design, P=-design.P),
        "W_min": dataclasses.replace(design, W=-design.W),
        "input": dataclasses.replace(design, rho=1e-3),
        "eps_ball": dataclasses.replace(design, epsilon=10.0),
    }
    for what, d in spoilt.items():
        with pytest.raises(PDCInfeasibleError, match=what):
            verify_design(d)
    # the robust design's extra models are checked too: the nominal gains of another model
    other = vertex_matrices(dataclasses.replace(NOMINAL, r=3 * NOMINAL.r))
    with pytest.raises(PDCInfeasibleError, match="of model 2"):
        verify_design(design, [design.model, dataclasses.replace(other, B=-other.B)])


def test_lyapunov_decreases_and_input_bound_holds_on_nonlinear_plant(design):
    """V = x^T P x along the nominal nonlinear plant; |u| <= rho from the epsilon ball."""
    rng = np.random.default_rng(1)
    n = 6
    x0 = rng.normal(size=(n, 4))
    x0 *= (EPS * rng.uniform(0.5, 1.0, (n, 1))) / np.linalg.norm(x0, axis=1, keepdims=True)
    x0[0] = [math.pi / 18, 0.0, 0.0, 0.0]
    ctl = PDCBalance(design, Ts=0.001)
    res = simulate(ctl, NOMINAL, q0=np.stack([x0[:, 2], x0[:, 0], 0 * x0[:, 0]], -1),
                   qdot0=np.stack([x0[:, 3], x0[:, 1], 0 * x0[:, 0]], -1),
                   duration=3.0, Ts=0.001)  # fmt: skip
    assert np.all(res.status == "ok")
    st = res.states  # (N, K, 8)
    x = np.stack([st[..., 1], st[..., 4], st[..., 0], st[..., 3]], -1)
    V = np.einsum("nki,ij,nkj->nk", x, design.P, x)
    assert np.all(V[:, 0] <= 1.0 + 1e-9)  # x0^T P x0 <= 1 (5.22)
    assert np.all(np.diff(V, axis=1) <= 1e-6 * V[:, :1])  # non-increasing
    u = np.einsum("nki,nki->nk", pdc_gain(design.G, x[..., 0]), x)
    assert np.max(np.abs(u)) <= RHO


def test_design_cli_function():
    doc, text = design_it2(EPS, RHO)
    assert doc["status"] == "optimal" and len(doc["G1"]) == 4 and "G2 =" in text
    doc_j, text_j = design_it2(EPS, RHO, as_json=True, robust=0.35)
    assert '"G1"' in text_j and doc_j["robust"] == 0.35
