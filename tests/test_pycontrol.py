"""python-control interop (issue 17 item 4): the linearisation as StateSpace, our LQR designs
against python-control's own lqr/dlqr on random parameter sets, and the nonlinear plant as a
NonlinearIOSystem against mwip's engine."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

ct = pytest.importorskip("control")

from mwip.laws.lqr.controller import BOOK_Q, BOOK_R, LQR, design_lqr  # noqa: E402
from mwip.models.linear import INPUT_NAMES, STATE_NAMES, linearize  # noqa: E402
from mwip.params import NOMINAL, REAL  # noqa: E402
from mwip.pycontrol import lqr_system, plant_system  # noqa: E402
from mwip.sim import simulate  # noqa: E402


def _random_robot(rng: np.random.Generator):
    scale = rng.uniform(0.6, 1.4, 11)
    names = ("mb", "mw", "Iby", "Ibz", "Iwa", "Iwd", "l", "b", "r", "Db", "Dw")
    pairs = zip(names, scale, strict=True)
    return replace(NOMINAL, **{n: getattr(NOMINAL, n) * s for n, s in pairs})


def test_statespace_matches_linearize():
    A, B = linearize(REAL)
    sys = linearize(REAL, as_statespace=True)
    assert sys.dt == 0 and sys.nstates == 5
    assert np.array_equal(sys.A, A) and np.array_equal(sys.B, B)
    assert list(sys.state_labels) == list(STATE_NAMES)
    assert list(sys.input_labels) == list(INPUT_NAMES)


def test_zoh_model_is_the_exact_discretisation():
    """ZOH sampling of python-control vs the matrix exponential of (A, B): for a constant
    input held over Ts the discrete step equals the exact continuous solution."""
    from scipy.integrate import solve_ivp

    A, B = linearize(REAL)
    sysd = linearize(REAL, as_statespace=True, Ts=0.005)
    assert sysd.dt == 0.005
    x0 = np.array([0.05, 0.1, -0.2, 0.3, 0.4])
    u = np.array([0.3, -0.1])
    sol = solve_ivp(lambda t, x: A @ x + B @ u, (0, 0.005), x0, rtol=1e-12, atol=1e-14)
    assert np.allclose(sysd.A @ x0 + sysd.B @ u, sol.y[:, -1], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_dlqr_signature_and_result_match_python_control_on_discrete_matrices(seed):
    """mwip.laws.dlqr(A, B, Q, R[, N]) as control.dlqr: discrete matrices in, (K, S, E)
    out, with and without a cross weight N, and the state-space form dlqr(sys, Q, R)."""
    from mwip.laws import dlqr

    rng = np.random.default_rng(seed)
    sysd = linearize(_random_robot(rng), as_statespace=True, Ts=0.005)
    Ad, Bd = sysd.A, sysd.B
    N = 0.01 * rng.standard_normal((5, 2))
    for extra in ((), (N,)):
        ours = dlqr(Ad, Bd, BOOK_Q, BOOK_R, *extra)
        theirs = ct.dlqr(Ad, Bd, BOOK_Q, BOOK_R, *extra)
        K, S, E = ours
        scale = np.abs(theirs[0]).max()
        assert np.allclose(K, theirs[0], rtol=1e-8, atol=1e-11 * scale)
        assert np.allclose(S, theirs[1], rtol=1e-8, atol=1e-11 * np.abs(theirs[1]).max())
        assert np.allclose(np.sort_complex(E), np.sort_complex(theirs[2]), rtol=1e-8, atol=1e-12)
    K_sys, _, _ = dlqr(sysd, BOOK_Q, BOOK_R)
    assert np.array_equal(K_sys, dlqr(Ad, Bd, BOOK_Q, BOOK_R)[0])
    with pytest.raises(ValueError, match="discrete-time system"):
        dlqr(linearize(NOMINAL, as_statespace=True), BOOK_Q, BOOK_R)


@pytest.mark.parametrize("seed", range(5))
def test_lqr_and_dlqr_agree_with_python_control(seed):
    p = _random_robot(np.random.default_rng(seed))
    K_ct, _, _ = ct.lqr(linearize(p, as_statespace=True), BOOK_Q, BOOK_R)
    K_ours = design_lqr(p, Ts=None).K
    assert np.allclose(K_ours, K_ct, rtol=1e-7, atol=1e-9 * np.abs(K_ct).max())
    K_dct, _, _ = ct.dlqr(linearize(p, as_statespace=True, Ts=0.005), BOOK_Q, BOOK_R)
    assert np.allclose(design_lqr(p, Ts=0.005).K, K_dct, rtol=1e-9, atol=1e-12)


def test_batched_params_rejected():
    batch = replace(REAL, mb=np.array([2.5, 2.6]))
    with pytest.raises(ValueError, match="one robot"):
        linearize(batch, as_statespace=True)
    with pytest.raises(ValueError, match="as_statespace"):
        linearize(REAL, Ts=0.005)


def test_nonlinear_closed_loop_matches_the_engine():
    """A moderate continuous LQR (designed on the real robot so both loops use the same r in
    v = r psi') closed around `plant_system` by python-control's interconnect and
    input_output_response, against mwip's continuous mode: same trajectory."""
    design = design_lqr(REAL, Q=np.diag([10.0, 1, 1, 1, 1]), R=np.eye(2), Ts=None)
    plant = plant_system(REAL)
    loop = ct.interconnect([plant, lqr_system(design)], inplist=[],
                           outlist=list(plant.output_labels))  # fmt: skip
    T = np.linspace(0.0, 3.0, 301)
    x0 = np.zeros(8)
    x0[1] = 0.15
    resp = ct.input_output_response(loop, T, 0, x0, solve_ivp_kwargs={"rtol": 1e-10,
                                                                        "atol": 1e-12})  # fmt: skip
    ours = simulate(LQR(design), REAL, q0=(0, 0.15, 0), duration=3.0, Ts=0.01, dt=0.0005,
                    mode="continuous")  # fmt: skip
    theta_ct = np.interp(ours.t, T, resp.outputs[0])
    assert np.max(np.abs(theta_ct - ours.state[:, 1])) < 1e-5
    assert abs(ours.state[-1, 1]) < 0.01  # and it balanced
