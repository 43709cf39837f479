"""The simulation engine: integrator accuracy, modes, batches, events, disturbances, export."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.models import reduced
from mwip.models.reduced import coefficients
from mwip.params import NOMINAL, NOMINAL_LITERAL, REAL, REAL_LITERAL, stack_params
from mwip.sim import SimResult, Sinusoid, simulate
from mwip.sim.engine import DEFAULT_DT_RK4, fastest_rate
from mwip.sim.kernel import RK4, ROS2W, advance


class Constant:
    """Open loop: a constant torque (or NaN to provoke divergence)."""

    Ts = None
    static = True

    def __init__(self, u=(0.0, 0.0)):
        self.u = np.asarray(u, dtype=float)

    def reset(self, meas):
        self.n = meas.y.shape[0]

    def __call__(self, t, meas):
        return np.broadcast_to(self.u, (meas.y.shape[0], 2)).copy()


def _kernel_run(p, y0, u, h, T, method=ROS2W):
    y = np.array(y0, dtype=float)[None].copy()
    n = int(round(T / h))
    st, te = np.zeros(1, np.int64), np.zeros(1)
    rows = n + 1 if method == ROS2W else 2 * n + 1
    advance(
        y,
        np.asarray([u], dtype=float),
        np.zeros((rows, 1, 3)),
        coefficients(p)[None],
        h,
        n,
        st,
        0.0,
        te,
        method,
    )
    return y[0]


def _radau(p, y0, u, T):
    def f(t, s):
        a = reduced.accelerations(p, s[:3], s[3:6], u)
        return np.r_[s[3:6], a, p.r * s[3] * np.cos(s[2]), p.r * s[3] * np.sin(s[2])]

    return solve_ivp(f, (0, T), y0, method="Radau", rtol=1e-12, atol=1e-12).y[:, -1]


def test_ros2w_second_order_against_radau_on_the_stiff_plant():
    y0 = np.array([0.0, 0.1, 0.0, 2.0, 0.0, 0.5, 0.0, 0.0])
    u = np.array([0.05, -0.02])
    ref = _radau(REAL_LITERAL, y0, u, 1.0)
    errs = [np.abs(_kernel_run(REAL_LITERAL, y0, u, h, 1.0) - ref).max()
            for h in (1e-3, 5e-4, 2.5e-4)]  # fmt: skip
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.7), orders
    assert errs[1] < 1e-4


def test_rk4_fourth_order_against_radau_on_the_units_plant():
    """Classical RK4 on the non-stiff plant: observed order ~4 between 20, 10, 5, 2.5 ms
    (0.2 s of the falling open loop, theta 0.01 -> -0.59 rad)."""
    y0 = np.array([0.0, 0.01, 0.0, 2.0, 0.0, 0.5, 0.0, 0.0])
    u = np.array([0.05, -0.02])
    ref = _radau(REAL, y0, u, 0.2)
    errs = [np.abs(_kernel_run(REAL, y0, u, h, 0.2, RK4) - ref).max()
            for h in (0.02, 0.01, 0.005, 0.0025)]  # fmt: skip
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 3.7) and np.all(orders < 4.3), orders
    assert errs[2] < 2e-5


def test_kernel_stable_where_rk4_is_not():
    """Literal-reading plant: at 2 ms (h*lambda ~ -6 on its damping modes) ROS2-W stays bounded
    and accurate while RK4 blows up."""
    y0 = np.array([0.0, 0.0, 0.0, 5.0, -5.0, 0.0, 0.0, 0.0])
    y = _kernel_run(REAL_LITERAL, y0, (0.0, 0.0), 2e-3, 0.2)
    ref = _kernel_run(REAL_LITERAL, y0, (0.0, 0.0), 1e-5, 0.2)
    assert np.all(np.isfinite(y)) and np.abs(y - ref)[:6].max() < 5e-3
    bad = _kernel_run(REAL_LITERAL, y0, (0.0, 0.0), 2e-3, 0.2, RK4)
    assert not np.all(np.abs(bad[:6] - ref[:6]) < 1.0)


def test_kernel_energy_error_converges_second_order():
    p = replace(REAL, Db=0.0, Dw=0.0)
    y0 = np.array([0.0, 0.05, 0.0, 3.0, -0.5, 2.0, 0.0, 0.0])
    E0 = reduced.energy(p, y0[:3], y0[3:6])
    drift = []
    for h in (1e-3, 1e-4):
        y = _kernel_run(p, y0, (0.0, 0.0), h, 0.8)
        drift.append(abs(reduced.energy(p, y[:3], y[3:6]) - E0) / E0)
    assert drift[1] < 1e-6 and drift[0] / drift[1] > 50


def test_rk4_energy_drift_without_damping_is_fourth_order():
    """Without damping the energy is conserved; RK4's drift falls ~16x per halving."""
    p = replace(REAL, Db=0.0, Dw=0.0)
    y0 = np.array([0.0, 0.05, 0.0, 3.0, -0.5, 2.0, 0.0, 0.0])
    E0 = reduced.energy(p, y0[:3], y0[3:6])
    drift = []
    for h in (4e-3, 2e-3, 1e-3):
        y = _kernel_run(p, y0, (0.0, 0.0), h, 0.8, RK4)
        drift.append(abs(reduced.energy(p, y[:3], y[3:6]) - E0) / E0)
    ratios = np.array(drift[:-1]) / np.array(drift[1:])
    assert np.all(ratios > 12) and drift[0] < 1e-6, (drift, ratios)


def test_integrator_chosen_by_stiffness():
    """Units reading: fastest rate ~24 rad/s, RK4 at one step per 5 ms sample; the literal
    reading (~3000 rad/s) and an explicit request keep ROS2-W at 0.5 ms."""
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    assert 20 < fastest_rate(coefficients(REAL)) < 30
    assert fastest_rate(coefficients(REAL_LITERAL)) > 2000
    a = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=0.1)
    assert (a.settings["integrator"], a.settings["dt"]) == ("RK4", DEFAULT_DT_RK4)
    b = simulate(ctrl, REAL_LITERAL, q0=(0, 0.1, 0), duration=0.1)
    assert (b.settings["integrator"], b.settings["dt"]) == ("ROS2-W", 0.0005)
    c = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=0.1, integrator="ros2w")
    assert (c.settings["integrator"], c.settings["dt"]) == ("ROS2-W", 0.0005)
    with pytest.raises(ValueError, match="integrator"):
        simulate(ctrl, REAL, duration=0.1, integrator="euler")


def test_default_step_within_1e4_of_a_4x_finer_reference():
    """The convergence criterion of docs/engine.md on the sampled LQR (units plant, 10 s):
    the default (RK4, one step per 5 ms sample) against RK4 at 1.25 ms."""
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    a = simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=10)
    b = simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=10, dt=0.00125)
    for part in (slice(0, 3), slice(3, 6)):  # angles, rates: relative to their largest value
        err = np.abs(a.states[..., part] - b.states[..., part]).max()
        assert err < 1e-4 * np.abs(b.states[..., part]).max()
    assert a.ok and abs(a.theta[-1]) < 1e-3


def test_halving_step_changes_stiff_closed_loop_lqr_by_less_than_1e4():
    ctrl = LQR(design_lqr(NOMINAL_LITERAL, Ts=0.005))
    a = simulate(ctrl, REAL_LITERAL, q0=(0, 0.1745, 0), duration=10)  # ROS2-W, 0.5 ms
    b = simulate(ctrl, REAL_LITERAL, q0=(0, 0.1745, 0), duration=10, dt=0.00025)
    assert a.settings["dt"] == 0.0005
    assert np.abs(a.states[..., :6] - b.states[..., :6]).max() < 1e-4
    assert a.ok and abs(a.theta[-1]) < 1e-3


def test_continuous_mode_book_lqr_balances_and_converges():
    ctrl = LQR(design_lqr(NOMINAL, Ts=None))
    a = simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=4, Ts=0.005, dt=1e-3, mode="continuous")
    b = simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=4, Ts=0.005, dt=5e-4, mode="continuous")
    assert a.ok and abs(a.theta[-1]) < 5e-3
    assert np.abs(a.theta - b.theta).max() < 1e-4


def test_continuous_gain_with_hold_stops_and_keeps_data():
    """SPEC section 2: the book's gain with 5 ms hold is violently unstable."""
    ctrl = LQR(design_lqr(NOMINAL, Ts=None))
    ctrl.Ts = None  # apply it sampled anyway
    res = simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=5, Ts=0.005)
    assert res.status[0] in ("fell", "diverged") and res.t_end[0] < 1.0
    assert res.t[-1] <= res.t_end[0] and np.all(np.isfinite(res.theta))
    assert len(res.t) > 1


def test_fell_event():
    res = simulate(Constant(), REAL, q0=(0, 0.3, 0), duration=10)
    assert res.status[0] == "fell"
    assert 0 < res.t_end[0] < 3
    assert abs(res.final_state[0, 1]) >= np.pi / 2
    # recorded up to the stop (a stop at a sample instant is recorded there)
    assert np.all(np.abs(res.theta[res.t < res.t_end[0]]) < np.pi / 2)
    assert res.t[-1] <= res.t_end[0] and np.all(np.isfinite(res.theta))


def test_diverged_event():
    res = simulate(Constant((np.nan, 0.0)), REAL, q0=(0, 0.0, 0), duration=1)
    assert res.status[0] == "diverged" and res.t_end[0] < 0.01


def test_batch_equals_single_runs():
    plants = [REAL, NOMINAL, REAL.with_payload()]
    q0 = np.array([[0, 0.1, 0], [0, -0.2, 0.3], [0, 0.05, 0]])
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    dist = Sinusoid(amplitude=(0.05, 0.05, 0.05), omega=(2, 1, 1))
    batch = simulate(ctrl, stack_params(plants), q0=q0, duration=3, disturbance=dist)
    assert batch.states.shape[0] == 3 and batch.batched
    for i, p in enumerate(plants):
        single = simulate(ctrl, p, q0=q0[i], duration=3, disturbance=dist)
        np.testing.assert_allclose(batch.states[i], single.states[0], rtol=0, atol=1e-12)


def test_batch_with_one_falling_plant_keeps_others_running():
    q0 = np.array([[0, 0.0, 0], [0, 0.3, 0]])  # exact equilibrium stays; the other falls
    res = simulate(Constant(), REAL, q0=q0, duration=3)
    assert list(res.status) == ["ok", "fell"]
    assert np.all(np.isnan(res.theta[1, res.t > res.t_end[1]]))
    assert np.all(np.isfinite(res.theta[0]))


def test_constant_yaw_disturbance_matches_analytic_solution():
    """tau_ext = (0, 0, c) on the upright robot: alpha' = c/k (1 - exp(-k t / m33))."""
    c = 0.02
    dist = Sinusoid(offset=(0.0, 0.0, c))
    res = simulate(Constant(), REAL, duration=2, disturbance=dist)
    k = 2 * REAL.b**2 / REAL.r**2 * (REAL.Db + REAL.Dw)
    exact = c / k * (1 - np.exp(-k * res.t / REAL.m33))
    # units reading: k / m33 ~ 4.9 1/s; RK4 at the default 5 ms is accurate to ~1e-8 relative
    # and its error falls ~2^4 per halving
    err = np.abs(res.q_dot[:, 2] - exact).max() / np.abs(exact).max()
    fine = simulate(Constant(), REAL, duration=2, disturbance=dist, dt=0.00125)
    err_fine = np.abs(fine.q_dot[:, 2] - exact).max() / np.abs(exact).max()
    assert err < 1e-7 and err / err_fine > 100, (err, err_fine)
    assert np.all(res.theta == 0.0) and np.all(res.q_dot[:, 0] == 0.0)
    # the literal reading's stiff yaw mode (k / m33 ~ 3000 1/s): ROS2-W (L-stable) is exact
    # once its 0.3 ms transient has decayed
    lit = simulate(Constant(), REAL_LITERAL, duration=0.2, disturbance=dist)
    p = REAL_LITERAL
    k = 2 * p.b**2 / p.r**2 * (p.Db + p.Dw)
    exact = c / k * (1 - np.exp(-k * lit.t / p.m33))
    late = lit.t > 0.02
    np.testing.assert_allclose(lit.q_dot[late, 2], exact[late], rtol=1e-10)


def test_equal_torques_drive_straight():
    res = simulate(Constant((0.01, 0.01)), REAL, q0=(0, 0.0, 0.3), duration=0.5)
    assert np.all(res.alpha == 0.3)
    # displacement stays on the line through the start with heading 0.3 (either direction)
    across = res.x * np.sin(0.3) - res.y * np.cos(0.3)
    assert np.abs(across).max() < 1e-15 and np.hypot(res.x[-1], res.y[-1]) > 5e-5


def test_zero_order_hold_and_sample_period():
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.01))
    res = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=1)
    assert res.settings["Ts"] == 0.01 and np.allclose(np.diff(res.t), 0.01)
    with pytest.raises(ValueError, match="differs from the controller's design period"):
        simulate(ctrl, REAL, duration=1, Ts=0.005)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0003}, "must divide"),
        ({"duration": -1.0}, "duration"),
        ({"Ts": 0.0}, "Ts must be"),
        ({"q0": (0, 0)}, "q0"),
        ({"mode": "fast"}, "mode"),
        ({"record_every": 0}, "record_every"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate(Constant(), REAL, **kwargs)


def test_continuous_mode_needs_static_controller():
    ctrl = Constant()
    ctrl.static = False
    with pytest.raises(ValueError, match="static"):
        simulate(ctrl, REAL, mode="continuous")


def test_export_round_trip(tmp_path):
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    res = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=0.5)
    res.to_npz(tmp_path / "r.npz")
    back = SimResult.from_npz(tmp_path / "r.npz")
    np.testing.assert_array_equal(back.states, res.states)
    np.testing.assert_array_equal(back.theta, res.theta)
    res.to_csv(tmp_path / "r.csv")
    data = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True)
    np.testing.assert_allclose(data["theta"], res.theta, rtol=1e-9)
    np.testing.assert_allclose(data["v"], REAL.r * res.q_dot[:, 0], rtol=1e-9, atol=1e-15)
    df = res.to_dataframe()
    assert {"t", "theta", "v", "x", "y", "u_r", "u_l"} <= set(df.columns) and len(df) == len(res.t)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_deterministic():
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    a = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=1, seed=3)
    b = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=1, seed=3)
    np.testing.assert_array_equal(a.states, b.states)


def test_threaded_kernel_equals_serial():
    from mwip.sim.kernel import advance_parallel

    rng = np.random.default_rng(7)
    n = 300
    y0 = np.zeros((n, 8))
    y0[:, 1] = rng.uniform(-0.3, 0.3, n)
    y0[:, 3:6] = rng.uniform(-1, 1, (n, 3))
    u = rng.uniform(-0.2, 0.2, (n, 2))
    coef = coefficients(stack_params([REAL, NOMINAL] * (n // 2)))
    tau = rng.uniform(-0.05, 0.05, (11, n, 3))
    outs = []
    for fn in (advance, advance_parallel):
        y, st, te = y0.copy(), np.zeros(n, np.int64), np.zeros(n)
        running = fn(y, u, tau, coef, 5e-4, 10, st, 0.0, te)
        outs.append((y, st, running))
    np.testing.assert_array_equal(outs[0][0], outs[1][0])
    assert outs[0][2] == outs[1][2] == n


class _Clip:
    """A torque-limited drive: the simplest actuator."""

    def __init__(self, limit):
        self.limit = limit

    def reset(self, n, seed=None):
        self.n = n

    def __call__(self, t, u_cmd, state):
        return np.clip(u_cmd, -self.limit, self.limit)


def test_actuator_hook_limits_applied_torque():
    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    free = simulate(ctrl, REAL, q0=(0, 0.3, 0), duration=2)
    lim = simulate(ctrl, REAL, q0=(0, 0.3, 0), duration=2, actuator=_Clip(0.15))
    applied = lim.series()["u_applied"]
    assert np.abs(free.u).max() > 0.2 and np.abs(applied).max() <= 0.15 + 1e-12
    assert np.abs(lim.u).max() > 0.15  # the command is recorded unclipped
    k = min(len(free.t), len(lim.t))
    assert np.abs(free.theta[:k] - lim.theta[:k]).max() > 1e-3
    with pytest.raises(ValueError, match="actuator"):
        simulate(LQR(design_lqr(NOMINAL, Ts=None)), REAL, mode="continuous", actuator=_Clip(1))
