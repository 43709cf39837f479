"""Tests of the sampled disturbance observers (3.2), (3.7), (3.20)-(3.23).

Most tests drive the observer with a synthetic plant whose velocity increments are generated
from a stand-in model ``F, G`` held over each sample plus the exact integral of a known
disturbance, ``q'_{k+1} = q'_k + Ts (F_k + G_k [u_A, u_B]_k) + int tau_d dt``. With
``model_hold="start"`` the observer's measured disturbance is then exactly the sample mean of
``tau_d``, so the observer's own error dynamics can be checked to rounding.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import scipy.linalg as sla

from mwip.observers import (
    HODO,
    FirstOrderDO,
    HighOrderDO,
    SecondOrderDO,
    discretize_observer,
    error_dynamics,
    euler_substeps_needed,
    published_gain_sets,
    stacked_gain,
)
from mwip.params import NOMINAL

Arr = np.ndarray


def fg_standin(p: object, q: Arr, qdot: Arr) -> tuple[Arr, Arr]:
    """A nonlinear stand-in for (2.36): F (N, 3) and G (N, 3, 2) acting on [u_A, u_B]."""
    th = q[:, 1]
    F = np.stack(
        [-2.0 * qdot[:, 0] + np.sin(th), -qdot[:, 1] + 3.0 * np.sin(th), -0.5 * qdot[:, 2]], 1
    )
    G = np.zeros((q.shape[0], 3, 2))
    G[:, 0, 0] = 1.0 + 0.2 * np.cos(th)
    G[:, 1, 0] = -(2.0 + 0.1 * np.cos(th))
    G[:, 2, 1] = 1.5
    return F, G


def fg_zero(p: object, q: Arr, qdot: Arr) -> tuple[Arr, Arr]:
    """A model with F = 0, G = 0 (where the model does not matter: cheaper)."""
    return np.zeros_like(q), np.zeros((q.shape[0], 3, 2))


def binomial(n: int, w: float) -> list[float]:
    """Gains v_i of (s + w)^n."""
    return [math.comb(n, i) * w**i for i in range(1, n + 1)]


def zoh_plant(
    Ts: float,
    K: int,
    tau_int: Callable[[float, float], Arr],
    N: int = 1,
    seed: int = 0,
    f_g: Callable[[object, Arr, Arr], tuple[Arr, Arr]] = fg_standin,
) -> tuple[Arr, Arr, Arr]:
    """Samples ``q (K+1, N, 3), qdot (K+1, N, 3), u (K, N, 2)`` of the synthetic plant."""
    rng = np.random.default_rng(seed)
    q = np.zeros((K + 1, N, 3))
    qd = np.zeros((K + 1, N, 3))
    q[0] = rng.normal(size=(N, 3)) * 0.1
    qd[0] = rng.normal(size=(N, 3)) * 0.1
    u = rng.normal(size=(K, N, 2)) * 0.1
    for k in range(K):
        F, G = f_g(None, q[k], qd[k])
        uAB = np.stack([u[k, :, 0] + u[k, :, 1], u[k, :, 0] - u[k, :, 1]], 1)
        f = F + np.einsum("nij,nj->ni", G, uAB)
        qd[k + 1] = qd[k] + Ts * f + tau_int(k * Ts, (k + 1) * Ts)
        q[k + 1] = q[k] + 0.5 * Ts * (qd[k] + qd[k + 1])
    return q, qd, u


def run(obs: HighOrderDO, q: Arr, qd: Arr, u: Arr, estimates0: Arr | None = None) -> Arr:
    """Estimates (K+1, N, n, 3) along a recorded run (index 0: after reset)."""
    obs.reset(qd[0], estimates0, q0=q[0])
    out = [obs.estimates]
    for k in range(u.shape[0]):
        obs.update(q[k + 1], qd[k + 1], u[k])
        out.append(obs.estimates)
    return np.array(out)


def poly_truth(c: Arr, deg: int, n: int, t: float) -> Arr:
    """``[tau, tau', ..., tau^(n-1)]`` (n, 3) of ``tau = c t^deg``."""
    rows = []
    for j in range(n):
        coef = math.perm(deg, j) if j <= deg else 0
        rows.append(c * coef * t ** max(deg - j, 0) if coef else 0.0 * c)
    return np.array(rows)


def poly_int(c: Arr, deg: int) -> Callable[[float, float], Arr]:
    return lambda t0, t1: c * (t1 ** (deg + 1) - t0 ** (deg + 1)) / (deg + 1)


C = np.array([1.0, -0.5, 2.0])


# ---------------------------------------------------------------------------------------------
# discretisation
# ---------------------------------------------------------------------------------------------


def test_discretize_exact_and_euler_matrices() -> None:
    v = [22.9778, 357.2853, 1831.5, 5737.7]
    Ts = 0.005
    D, _ = error_dynamics(v)
    Lc = stacked_gain(v)
    Phi, Gam = discretize_observer(v, Ts, "exact")
    np.testing.assert_allclose(Phi, sla.expm(D * Ts), rtol=1e-12, atol=1e-12)
    # Gamma = int_0^Ts expm(D s) ds Lc = D^-1 (Phi - I) Lc
    np.testing.assert_allclose(Gam, np.linalg.solve(D, (Phi - np.eye(12)) @ Lc), atol=1e-9)
    PhiE, GamE = discretize_observer(v, Ts, "euler")
    np.testing.assert_allclose(PhiE, np.eye(12) + Ts * D)
    np.testing.assert_allclose(GamE, Ts * Lc)
    Phi3, _ = discretize_observer(v, Ts, "euler", substeps=3)
    np.testing.assert_allclose(Phi3, np.linalg.matrix_power(np.eye(12) + Ts / 3 * D, 3))
    with pytest.raises(ValueError, match="discretization"):
        discretize_observer(v, Ts, "tustin")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="Ts"):
        discretize_observer(v, 0.0)


@pytest.mark.parametrize("method", ["exact", "euler"])
def test_observer_error_transition_is_the_discretised_D_n(method: str) -> None:
    # General (non-scalar) gains: L_i = v_i I3 + a seeded perturbation, still Hurwitz.
    rng = np.random.default_rng(7)
    n, Ts = 3, 0.005
    gains = [vi * np.eye(3) + 0.05 * vi * rng.normal(size=(3, 3)) for vi in binomial(n, 15.0)]
    D, _ = error_dynamics(gains)
    assert np.max(np.linalg.eigvals(D).real) < 0
    N = 3 * n
    tau = np.array([0.3, -0.2, 0.5])  # constant disturbance
    q, qd, u = zoh_plant(Ts, 4, lambda t0, t1: tau * (t1 - t0), N=N, seed=3)
    # one plant per unit initial error:  e_0 = truth - z_0 = -I (column j for plant j)
    truth = np.concatenate([tau, np.zeros(3 * (n - 1))])
    z0 = truth[None, :] + np.eye(N)
    est = run(HighOrderDO(NOMINAL, gains, Ts, method, model_hold="start", f_g=fg_standin),
              q, qd, u, z0.reshape(N, n, 3))  # fmt: skip
    err = truth[None, None, :] - est.reshape(est.shape[0], N, 3 * n)  # (K+1, N, 3n)
    expected = sla.expm(D * Ts) if method == "exact" else np.eye(N) + Ts * D
    for k in range(4):
        # columns of the transition matrix: e_{k+1} = M e_k for every plant
        M = np.linalg.solve(err[k], err[k + 1]).T
        np.testing.assert_allclose(M, expected, atol=1e-10)
    if method == "exact":
        lam = np.log(np.linalg.eigvals(expected).astype(complex)) / Ts
        for ev in np.linalg.eigvals(D):  # the sampled error decays with the eigenvalues of D_n
            assert np.min(np.abs(lam - ev)) < 1e-6 * abs(ev)


# ---------------------------------------------------------------------------------------------
# steady-state behaviour on polynomial disturbances
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_constant_disturbance_zero_steady_state_error(n: int) -> None:
    Ts = 0.005
    q, qd, u = zoh_plant(Ts, 400, poly_int(C, 0), N=2, seed=n)
    est = run(HODO(NOMINAL, binomial(n, 20.0), Ts, model_hold="start", f_g=fg_standin), q, qd, u)
    err = est[-1] - poly_truth(C, 0, n, 2.0)[None]
    assert np.max(np.abs(err)) < 1e-9
    assert np.max(np.abs(est[10] - poly_truth(C, 0, n, 0.05)[None])) > 1e-3  # it did converge


@pytest.mark.parametrize("n", [2, 3, 4])
def test_polynomial_of_degree_n_minus_1_error_vanishes_as_Ts_squared(n: int) -> None:
    # The continuous observer has zero steady-state error for degree < n. Sampled with the
    # sample mean held, the residual is a pure O(Ts^2) bias: quartered when Ts is halved.
    deg, T = n - 1, 2.0
    errs = []
    for Ts in (0.005, 0.0025):
        K = int(round(T / Ts))
        q, qd, u = zoh_plant(Ts, K, poly_int(C, deg), seed=1)
        obs = HODO(NOMINAL, binomial(n, 20.0), Ts, model_hold="start", f_g=fg_standin)
        est = run(obs, q, qd, u)
        errs.append(est[-1, 0, 0] - poly_truth(C, deg, n, T)[0])
    ratio = errs[0] / errs[1]
    np.testing.assert_allclose(ratio, 4.0, rtol=0.03)
    scale = math.factorial(deg) * np.abs(C)  # |tau^(n-1)|
    assert np.all(np.abs(errs[0]) < 2e-3 * scale)


@pytest.mark.parametrize("n", [1, 2])
def test_polynomial_of_degree_n_leaves_the_predicted_offset(n: int) -> None:
    # degree n: w = tau^(n) = n! c is constant and e -> -D_n^-1 E w, i.e. tau~ = n! c / v_n.
    Ts, T = 0.001, 1.5
    v = binomial(n, 20.0)
    q, qd, u = zoh_plant(Ts, int(round(T / Ts)), poly_int(C, n), seed=2)
    est = run(HODO(NOMINAL, v, Ts, model_hold="start", f_g=fg_standin), q, qd, u)
    err = poly_truth(C, n, n, T)[0] - est[-1, 0, 0]  # tau~ = tau - tau^  (3.26)
    np.testing.assert_allclose(err, math.factorial(n) * C / v[-1], rtol=0.02)


# ---------------------------------------------------------------------------------------------
# exact vs Euler with the book's gains (Ts = 5 ms)
# ---------------------------------------------------------------------------------------------

AMP = np.array([1.0, 0.5, 0.5])
OMEGA = np.array([2.0, 1.0, 1.0])
PHASE = np.array([math.pi / 2, 0.0, 0.0])


def sin_int(t0: float, t1: float) -> Arr:
    """Exact integral of the book's disturbance shape AMP sin(OMEGA t + PHASE)."""
    return AMP / OMEGA * (np.cos(OMEGA * t0 + PHASE) - np.cos(OMEGA * t1 + PHASE))


def test_exact_and_euler_agree_at_5ms_with_the_book_gains() -> None:
    # Compared after the start-up transient (t >= 3 s), on the disturbance response.
    # Tolerance 2e-4 of the amplitude for Euler with 100 substeps: its global error is
    # O(h |lambda|) relative, h = 50 us and |lambda| <= 99 rad/s, and much smaller at the
    # disturbance frequencies (1-2 rad/s); measured about 5e-5 for every set.
    # Plain Euler (one step per 5 ms sample) is within 1 % for do4 and do4_optimal, but it
    # moves do3's lightly damped poles -1.76 +- 20.3j to an effective -0.73 +- 20.4j, so its
    # transient lingers (10 % of the amplitude at t = 3 s); and it is unstable for do2.
    Ts, T = 0.005, 6.0
    q, qd, u = zoh_plant(Ts, int(round(T / Ts)), sin_int, seed=4, f_g=fg_zero)
    k0 = int(round(3.0 / Ts))
    for name, s in published_gain_sets().items():
        kw = {"model_hold": "start", "f_g": fg_zero}
        ex = run(HODO(NOMINAL, s.v, Ts, "exact", **kw), q, qd, u)[k0:, 0, 0]
        eu = run(HODO(NOMINAL, s.v, Ts, "euler", substeps=100, **kw), q, qd, u)[k0:, 0, 0]
        assert np.max(np.abs(ex - eu) / AMP) < 2e-4, name
        if name in ("do4", "do4_optimal"):
            e1 = run(HODO(NOMINAL, s.v, Ts, "euler", **kw), q, qd, u)[k0:, 0, 0]
            assert np.max(np.abs(ex - e1) / AMP) < 0.01, name
        elif name == "do3":
            e1 = run(HODO(NOMINAL, s.v, Ts, "euler", **kw), q, qd, u)[k0:, 0, 0]
            assert np.max(np.abs(ex - e1) / AMP) > 0.05, name


def test_forward_euler_stability_of_the_book_sets() -> None:
    sets = published_gain_sets()
    Ts = 0.005
    assert euler_substeps_needed(sets["do2"].v, Ts) == 7
    for name in ("do3", "do4", "do4_optimal"):
        assert euler_substeps_needed(sets[name].v, Ts) == 1
        HODO(NOMINAL, sets[name].v, Ts, "euler", f_g=fg_standin)  # accepted
    with pytest.raises(ValueError, match=r"unstable.*substeps >= 7"):
        HODO(NOMINAL, sets["do2"].v, Ts, "euler", f_g=fg_standin)
    HODO(NOMINAL, sets["do2"].v, Ts, "euler", substeps=7, f_g=fg_standin)
    obs = HODO(NOMINAL, sets["do2"].v, Ts, "exact", f_g=fg_standin)
    assert np.max(np.abs(np.linalg.eigvals(obs.Phi))) < 1.0


# ---------------------------------------------------------------------------------------------
# named forms, batching, wiring
# ---------------------------------------------------------------------------------------------


def test_first_and_second_order_are_hodo_n1_n2() -> None:
    Ts = 0.005
    q, qd, u = zoh_plant(Ts, 200, sin_int, N=3, seed=5)
    L = np.diag([10.0, 12.0, 8.0])
    a = run(FirstOrderDO(NOMINAL, L, Ts, f_g=fg_standin), q, qd, u)
    b = run(HighOrderDO(NOMINAL, [L], Ts, f_g=fg_standin), q, qd, u)
    np.testing.assert_array_equal(a, b)
    obs2 = SecondOrderDO(NOMINAL, 16.7, 209.9, Ts, f_g=fg_standin)
    c = run(obs2, q, qd, u)
    d = run(HighOrderDO(NOMINAL, [16.7, 209.9], Ts, f_g=fg_standin), q, qd, u)
    np.testing.assert_array_equal(c, d)
    np.testing.assert_array_equal(obs2.tau_hat_dot, c[-1, :, 1])


def test_batch_is_independent_per_plant() -> None:
    Ts = 0.005
    q, qd, u = zoh_plant(Ts, 100, sin_int, N=4, seed=6)
    v = published_gain_sets()["do4"].v
    batch = run(HODO(NOMINAL, v, Ts, f_g=fg_standin), q, qd, u)
    for i in range(4):
        one = run(HODO(NOMINAL, v, Ts, f_g=fg_standin), q[:, i : i + 1], qd[:, i : i + 1],
                  u[:, i : i + 1])  # fmt: skip
        np.testing.assert_allclose(batch[:, i : i + 1], one, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("hold", ["start", "end", "trapezoid"])
def test_model_hold_one_step_by_hand(hold: str) -> None:
    Ts, v = 0.005, [5.0, 30.0]
    rng = np.random.default_rng(8)
    q0, qd0, q1, qd1 = (rng.normal(size=(2, 3)) for _ in range(4))
    u = rng.normal(size=(2, 2))
    z0 = rng.normal(size=(2, 2, 3))
    obs = HODO(NOMINAL, v, Ts, model_hold=hold, f_g=fg_standin)
    obs.reset(qd0, z0, q0=q0)
    got = obs.update(q1, qd1, u)
    uAB = np.stack([u[:, 0] + u[:, 1], u[:, 0] - u[:, 1]], 1)

    def f(q: Arr, qd: Arr) -> Arr:
        F, G = fg_standin(None, q, qd)
        return F + np.einsum("nij,nj->ni", G, uAB)

    fk = {"start": f(q0, qd0), "end": f(q1, qd1), "trapezoid": 0.5 * (f(q0, qd0) + f(q1, qd1))}
    d = (qd1 - qd0) / Ts - fk[hold]
    Phi, Gam = discretize_observer(v, Ts)
    z1 = z0.reshape(2, 6) @ Phi.T + d @ Gam.T
    np.testing.assert_allclose(got, z1[:, :3], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(obs.estimates, z1.reshape(2, 2, 3), rtol=1e-12, atol=1e-12)


def test_reset_defaults_and_auxiliary_states() -> None:
    v = [6.1211, 423.8938, 1078.3]
    obs = HODO(NOMINAL, v, 0.005, f_g=fg_standin)
    qd0 = np.array([[1.0, 2.0, 3.0], [0.0, -1.0, 0.5]])
    obs.reset(qd0)
    assert obs.estimates.shape == (2, 3, 3) and np.all(obs.estimates == 0.0)
    # (3.20) with zero estimates: p_i = -L_i q'_0
    expected = -np.array([[vi * row for vi in v] for row in qd0])
    np.testing.assert_allclose(obs.auxiliary, expected)
    obs.reset(qd0, estimates0=np.ones((3, 3)))  # (n, 3) broadcasts over plants
    assert np.all(obs.tau_hat == 1.0)


def test_api_validation() -> None:
    obs = HODO(NOMINAL, [20.0], 0.005, f_g=fg_standin)
    with pytest.raises(RuntimeError, match="reset"):
        obs.update(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 2)))
    obs.reset(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"u \(N, 2\)"):
        obs.update(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="Hurwitz"):
        HODO(NOMINAL, [1.0, -1.0], 0.005, f_g=fg_standin)
    with pytest.raises(ValueError, match="model_hold"):
        HODO(NOMINAL, [1.0], 0.005, model_hold="mid", f_g=fg_standin)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="estimates0"):
        obs.reset(np.zeros((2, 3)), estimates0=np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="qdot0"):
        obs.reset(np.zeros((2, 2)))


def test_wiring_with_the_reduced_model() -> None:
    # The default model is mwip.models.reduced.f_g; on an Euler-discretised real-parameter
    # plant the observer (model_hold="start") must filter exactly the lumped disturbance
    # reduced.lumped_disturbance(NOMINAL, ...) of (2.36) (G acts on [u_A, u_B]).
    reduced = pytest.importorskip("mwip.models.reduced")
    from mwip.params import REAL

    Ts, K = 2e-4, 300
    rng = np.random.default_rng(9)
    q = np.array([[0.0, 0.05, 0.0], [0.1, -0.03, 0.2]])
    qd = np.array([[0.5, 0.0, 0.1], [-0.3, 0.2, -0.4]])
    v = published_gain_sets()["do4"].v
    obs = HODO(NOMINAL, v, Ts, model_hold="start")
    obs.reset(qd, q0=q)
    Phi, Gam = discretize_observer(v, Ts)
    z = np.zeros((2, 12))
    for _ in range(K):
        u = rng.normal(size=(2, 2)) * 0.05
        ext = rng.normal(size=(2, 3)) * 0.01
        a = reduced.accelerations(REAL, q, qd, u, ext)
        d = reduced.lumped_disturbance(NOMINAL, q, qd, a, u)
        z = z @ Phi.T + d @ Gam.T
        q, qd = q + Ts * qd, qd + Ts * a
        got = obs.update(q, qd, u)
    assert np.max(np.abs(d)) > 1.0  # a real model mismatch was estimated
    np.testing.assert_allclose(got, z[:, :3], rtol=1e-8, atol=1e-8)


def test_decoupled_observer_step_equals_the_dense_product() -> None:
    """Diagonal gains leave the channels of z uncoupled: every entry of Phi, Gamma linking two
    channels is an exact zero, and the kernel's structured product (which skips them) equals
    the dense one bit for bit; one non-zero coupling entry anywhere is detected."""
    from mwip.observers._hodo_kernel import channels_decoupled, observer_step

    rng = np.random.default_rng(11)
    for gains in (published_gain_sets()["do4"].gains, [np.diag(rng.uniform(1, 9, 3)) * 10**i
                                                       for i in range(3)], [30.0]):  # fmt: skip
        Phi, Gam = discretize_observer(gains, 0.005)
        m = Phi.shape[0]
        chan = np.arange(m) % 3
        off = chan[:, None] != chan[None, :]
        assert np.all(Phi[off] == 0.0) and np.all(Gam[chan[:, None] != np.arange(3)] == 0.0)
        assert np.count_nonzero(Phi) == m * m // 3
        assert channels_decoupled(Phi, Gam)
        for _ in range(5):
            z, d = rng.normal(size=m) * 10.0 ** rng.integers(-3, 3, m), rng.normal(size=3)
            zs, zd, w = z.copy(), z.copy(), np.empty(m)
            observer_step(Phi, Gam, True, zs, d[0], d[1], d[2], w)
            observer_step(Phi, Gam, False, zd, d[0], d[1], d[2], w)
            np.testing.assert_array_equal(zs, zd)
            np.testing.assert_allclose(zs, Phi @ z + Gam @ d, rtol=1e-13, atol=1e-13)
        for a, b in zip(*np.nonzero(off), strict=True):
            P = Phi.copy()
            P[a, b] = 1e-300
            assert not channels_decoupled(P, Gam)
        for a in range(m):
            G = Gam.copy()
            G[a, (a + 1) % 3] = -1e-300
            assert not channels_decoupled(Phi, G)
