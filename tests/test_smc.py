"""Sliding-mode family (Sec. 3.5): gains, design checks, closed-loop behaviour."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mwip.laws.smc.controller import (
    SlidingModeController,
    SMCDesignWarning,
    SMCGains,
    gains_from_bounds,
    make_smc,
)
from mwip.laws.smc.design import check_smc_design, sliding_matrix
from mwip.laws.switching import Switching
from mwip.models.reduced import mass_matrix
from mwip.params import NOMINAL, NOMINAL_LITERAL
from mwip.sim import Sinusoid, simulate

BOOK = (3.0, 0.2, 0.3, 3.0)


def test_gains_from_bounds_351():
    g = gains_from_bounds(BOOK, (3, 3, 3), (1, 1))
    assert (g.K1, g.K2) == (pytest.approx(4.9), 4.0)  # 3 + 0.3*3 + 1, 3 + 1
    g = gains_from_bounds(BOOK, (15, 15, 15), (1, 1))
    assert (g.K1, g.K2) == (pytest.approx(20.5), 16.0)
    with pytest.raises(ValueError, match="gamma"):
        gains_from_bounds(BOOK, (3, 3, 3), (0, 1))
    with pytest.raises(ValueError, match="lambdas"):
        SMCGains((3, -1, 0.3, 3), 1.0, 1.0)


def _z(c):
    p = NOMINAL
    return p.m11 + p.m12 * c, p.m22 + p.m12 * c


def test_design_check_book_lambdas_hold_with_hand_values():
    rep = check_smc_design(BOOK, NOMINAL, theta_max=0.35)
    assert rep.ok
    by = {c.name: c for c in rep.conditions}
    assert by["(3.52a)"].value == pytest.approx(3 * 0.3 - 0.2)
    z1c, z2c = _z(np.cos(0.35))
    z1u, z2u = _z(1.0)
    # z1 - l3 z2 = (m11 - 0.3 m22) + 0.7 m12 c: smallest at the smallest cos
    assert by["(3.52b)"].value == pytest.approx(z1c - 0.3 * z2c, rel=1e-9)
    # l2 z2 - l1 z1 = (0.2 m22 - 3 m11) - 2.8 m12 c: largest at the smallest cos
    assert by["(3.52c)"].value == pytest.approx(0.2 * z2c - 3 * z1c, rel=1e-9)
    assert by["(3.52d)"].value == pytest.approx(0.2 * (0.3 * z2c - z1c), rel=1e-9)
    # g2 + l3 g1 = (l3 z2 - z1) / Delta1 at upright
    d1 = NOMINAL.m11 * NOMINAL.m22 - NOMINAL.m12**2
    assert by["(3.50)"].value >= (0.3 * z2u - z1u) / d1 - 1e-9


@pytest.mark.parametrize(
    ("lambdas", "fails"),
    [
        ((3.0, 1.0, 0.3), {"(3.52a)"}),  # l1 l3 = 0.9 < l2 = 1
        ((3.0, 0.2, 1.0), {"(3.52b)", "(3.52d)"}),  # l3 = 1: z1 - z2 = m11 - m22 < 0
        ((1.0, 0.6, 0.3), {"(3.52a)", "(3.52c)"}),  # 0.6 z2 > z1 near upright
    ],
)
def test_design_check_violations(lambdas, fails):
    rep = check_smc_design(lambdas, NOMINAL, theta_max=0.35)
    failed = {c.name for c in rep.failed if c.name.startswith("(3.52")}
    assert failed == fails
    if "(3.52b)" in fails:
        by = {c.name: c for c in rep.conditions}
        assert by["(3.52b)"].value == pytest.approx(NOMINAL.m11 - NOMINAL.m22, rel=1e-12)


def test_hurwitz_conditions_equal_eigenvalue_test():
    """(3.66) agrees with the eigenvalues, without and with the wheel damping, under both
    readings of the tables' damping (the literal one makes the damping terms dominant)."""
    rng = np.random.default_rng(3)
    agree = total = 0
    for p in (NOMINAL, NOMINAL_LITERAL):
        for _ in range(150):
            lam = rng.uniform(0.01, 5.0, 3)
            lam[1] /= 10.0  # l2 < l1 l3 is needed: draw it smaller so both outcomes are common
            for damping in (False, True):
                rep = check_smc_design(lam, p, theta_max=0.0, damping=damping)
                by = {c.name: c.holds for c in rep.conditions}
                hurwitz = by["(3.66a)"] and by["(3.66b)"] and by["(3.66c)"]
                assert hurwitz == by["eig"], (lam, damping)
                agree += hurwitz
                total += 1
    assert 0.05 * total < agree < 0.95 * total  # both outcomes occur


def test_sliding_matrix_by_finite_differences():
    """A of (3.65) equals the Jacobian of the sliding dynamics (3.58)-(3.59)."""
    p, (l1, l2, l3, _) = NOMINAL, BOOK

    def pi(x):
        q2, q2d, q1d = x
        c, s = np.cos(q2), np.sin(q2)
        z1, z2 = p.m11 + p.m12 * c, p.m22 + p.m12 * c
        h = p.m12 * s * q2d**2 + p.Gb * s - 2 * p.Dw * q1d
        a = np.linalg.solve([[l3, 1.0], [z1, z2]], [-l1 * q2d - l2 * q1d, h])
        return np.array([q2d, a[1], a[0]])

    eps = 1e-7
    J = np.column_stack([(pi(eps * e) - pi(-eps * e)) / (2 * eps) for e in np.eye(3)])
    np.testing.assert_allclose(sliding_matrix(BOOK, NOMINAL, damping=True), J, rtol=1e-6, atol=1e-6)


def test_failing_design_warns_but_runs():
    with pytest.warns(SMCDesignWarning, match=r"\(3.52a\)"):
        ctrl = SlidingModeController(SMCGains((1.0, 0.5, 0.3, 3.0), 1.0, 1.0), Ts=0.001)
    res = simulate(ctrl, NOMINAL, q0=(0, 0.05, 0), duration=0.2, Ts=0.001)
    assert len(res.t) > 1


def test_reaching_phase_and_band_on_nominal_plant():
    """No disturbance, no mismatch: S1' = -K1 sgn(S1), so S1 falls linearly and reaches zero
    at |S1(0)| / K1 (exact law in continuous mode); sampled, it then stays in the relay's band
    K1 Ts, which halves with Ts."""
    s0 = 3.0 * np.pi / 18  # S1(0) = l1 theta0
    ctrl = SlidingModeController(SMCGains(BOOK, 1.0, 1.0), None, NOMINAL, 0.001)
    assert ctrl.static
    res = simulate(ctrl, NOMINAL, q0=(0, np.pi / 18, 0), duration=1.5, Ts=0.001,
                   mode="continuous")  # fmt: skip
    l1, l2, l3, _ = BOOK
    s1 = res.q_dot[:, 1] + l1 * res.theta + l2 * res.q[:, 0] + l3 * res.q_dot[:, 0]
    t_r = s0 / 1.0
    before, after = res.t < t_r - 0.01, res.t > t_r + 0.02
    np.testing.assert_allclose(s1[before], s0 - res.t[before], atol=1e-3)
    assert np.abs(s1[after]).max() < 1e-3
    bands = []
    for Ts in (0.001, 0.0005):
        ctrl = SlidingModeController(SMCGains(BOOK, 1.0, 1.0), None, NOMINAL, Ts)
        res = simulate(ctrl, NOMINAL, q0=(0, np.pi / 18, 0), duration=3, Ts=Ts)
        s1 = res.series()["S1"]
        assert s1[0] == pytest.approx(s0)
        bands.append(np.abs(s1[res.t > 1.0]).max())
        # the relay's one-sample step K1 Ts, up to the O(Ts^2) drift of the held equivalent
        # control
        assert bands[-1] == pytest.approx(1.0 * Ts, rel=0.005)
        assert abs(res.theta[-1]) < 0.01  # theta converges along the sliding dynamics
    assert bands[1] == pytest.approx(0.5 * bands[0], rel=0.01)


class _OracleSMC(SlidingModeController):
    """Test double: the true lumped disturbance instead of an observer (nominal plant, so
    tau_d = M^-1 tau_ext exactly); static so it runs inside the ODE right-hand side."""

    static = True

    def __init__(self, dist, **kw):
        super().__init__(SMCGains(BOOK, 0.0, 0.0), None, NOMINAL, 0.001, check=False, **kw)
        self.dist = dist

    def disturbance_estimate(self, t, meas):
        e = np.broadcast_to(self.dist(np.array([t]))[0], (meas.q.shape[0], 3))
        return np.linalg.solve(mass_matrix(NOMINAL, meas.q), e[..., None])[..., 0]


def test_true_disturbance_gives_ideal_sliding_dynamics():
    """With the true disturbance the loop stays on S1 = 0 and theta, psi' follow (3.58)-(3.59)
    integrated separately; the remaining difference is the plant integrator's (second order:
    halving the step divides it by about 4)."""
    dist = Sinusoid(amplitude=(0.05, 0.05, 0.0), omega=(2.0, 1.0, 1.0), phase=(np.pi / 2, 0, 0))
    l1, l2, l3, _ = BOOK
    th0 = 0.1
    p = NOMINAL

    def reduced(t, x):  # (3.58)-(3.59) with the wheel damping, alpha' = 0
        th, thd, psid = x
        c, s = np.cos(th), np.sin(th)
        z1, z2 = p.m11 + p.m12 * c, p.m22 + p.m12 * c
        d = dist(np.array([t]))[0]
        h = p.m12 * s * thd**2 + p.Gb * s - 2 * p.Dw * psid + d[0] + d[1]
        a = np.linalg.solve([[l3, 1.0], [z1, z2]], [-l1 * thd - l2 * psid, h])
        return [thd, a[1], a[0]]

    errors = []
    for dt in (0.0005, 0.00025):
        res = simulate(_OracleSMC(dist), NOMINAL, q0=(0, th0, 0), qdot0=(0, -l1 * th0, 0),
                       duration=3.0, Ts=0.001, dt=dt, mode="continuous",
                       disturbance=dist)  # fmt: skip
        assert res.ok
        s1 = res.q_dot[:, 1] + l1 * res.theta + l2 * res.q[:, 0] + l3 * res.q_dot[:, 0]
        assert np.abs(s1).max() < 1e-6  # stays on the surface
        # (3.59) uses the position term l2 (q1 - q1d' t) through S1 = 0; differentiate S1 = 0:
        # q2'' + l1 q2' + l2 q1' + l3 q1'' = 0 is exactly what `reduced` imposes.
        sol = solve_ivp(reduced, (0, 3), [th0, -l1 * th0, 0.0], t_eval=res.t, rtol=1e-10,
                        atol=1e-12)  # fmt: skip
        errors.append(
            (np.abs(res.theta - sol.y[0]).max(), np.abs(res.q_dot[:, 0] - sol.y[2]).max())
        )
        if dt == 0.0005:
            assert errors[-1][0] < 2e-5
            assert errors[-1][1] < 2e-4 * np.abs(sol.y[2]).max()
    ratio = np.array(errors[0]) / np.array(errors[1])
    assert np.all((3.5 < ratio) & (ratio < 4.5)), ratio


def test_observer_in_the_loop_estimates_and_make_smc():
    ctrl = make_smc("hodosmc", BOOK, dbar=(3, 3, 3), Ts=0.001)
    assert ctrl.gains.K1 == pytest.approx(4.9) and ctrl.observer.order == 4
    dist = Sinusoid(amplitude=(0.05, 0.05, 0.05), omega=(2, 1, 1))
    res = simulate(ctrl, NOMINAL, q0=(0, 0.1, 0), duration=4, Ts=0.001, disturbance=dist)
    assert res.ok and abs(res.theta[-1]) < 0.02
    tau_hat = res.series()["tau_hat"]
    assert tau_hat.shape == (len(res.t), 3) and np.abs(tau_hat[-1]).max() > 1.0
    with pytest.raises(ValueError, match="exactly one"):
        make_smc("smc", BOOK)
    with pytest.raises(ValueError, match="kind"):
        make_smc("pid", BOOK, dbar=(1, 1, 1))


def test_saturation_reduces_chattering():
    from mwip.metrics import total_variation_rate

    tv = {}
    for kind in ("sign", "sat"):
        ctrl = SlidingModeController(SMCGains(BOOK, 5.0, 5.0), None, NOMINAL, 0.001,
                                     switching=Switching(kind, 0.05))  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            res = simulate(ctrl, NOMINAL, q0=(0, 0.1, 0), duration=3, Ts=0.001)
        assert res.ok
        tv[kind] = total_variation_rate(res.t, res.u.T).sum()
    assert tv["sat"] < 0.2 * tv["sign"]
