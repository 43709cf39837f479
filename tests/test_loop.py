"""The compiled closed loop (mwip.sim.loop) equals the Python loop of the engine.

Both call the same compiled law kernels with the same arguments in the same order, so a run
must agree to round-off (here: exactly, bit for bit, on this machine; the tolerance allows a
few ulps should a compiler reorder a sum).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip.laws import registry
from mwip.observers import HighOrderDO
from mwip.params import NOMINAL, REAL, REAL_LITERAL, stack_params
from mwip.sim import Sinusoid, simulate

COMPILED = ("lqr", "dlqr", "smc", "do1smc", "hodosmc", "tsmc", "asta", "asmc", "it2", "t1")


def _pair(name, plant, Ts="default", **kw):
    out = []
    for compiled in (True, False):
        ctrl = registry.build(name, NOMINAL, Ts=Ts)
        out.append(simulate(ctrl, plant, compiled=compiled, **kw))
    return out


def _same(a, b):
    assert a.settings.pop("compiled") and not b.settings.pop("compiled")
    assert a.settings == b.settings
    assert list(a.status) == list(b.status)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.t_end, b.t_end)
    for x, y in [(a.states, b.states), (a.inputs, b.inputs), (a.final_state, b.final_state)]:
        assert x.shape == y.shape
        np.testing.assert_array_equal(np.isnan(x), np.isnan(y))
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-14)
    assert list(a.logs) == list(b.logs)
    for k in a.logs:
        np.testing.assert_allclose(a.logs[k], b.logs[k], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("name", COMPILED)
def test_single_run_equals_python_loop(name):
    a, b = _pair(name, REAL, q0=(0.0, 0.15, 0.1), qdot0=(0.5, 0.0, 0.2), duration=1.0)
    assert a.settings["integrator"] == "RK4"
    _same(a, b)


def test_hodosmc_1ms_batch_disturbance_decimation_and_stops():
    """A batch (parameters varied, one plant falls), a sinusoidal disturbance, records every
    7th sample, the 4th-order observer at 1 ms and the stiff ROS2-W path on the literal plant."""
    rng = np.random.default_rng(1)
    plants = [replace(REAL, mb=REAL.mb * f, l=REAL.l * g)
              for f, g in 1 + 0.2 * rng.uniform(-1, 1, (5, 2))]  # fmt: skip
    q0 = np.zeros((5, 3))
    q0[:, 1] = [0.05, -0.1, 0.15, 0.0, 1.4]
    qd0 = np.zeros((5, 3))
    qd0[4, 1] = 10.0
    dist = Sinusoid(amplitude=(0.1, 0.2, 0.05), omega=(1.0, 2.0, 3.0))
    kw = dict(q0=q0, qdot0=qd0, duration=1.0, disturbance=dist, record_every=7)
    a, b = _pair("hodosmc", stack_params(plants), Ts=0.001, **kw)
    assert "fell" in list(a.status) and "ok" in list(a.status)
    _same(a, b)
    lit = [replace(REAL_LITERAL, mb=p.mb, l=p.l) for p in plants]
    a, b = _pair("smc", stack_params(lit), **kw)
    assert a.settings["integrator"] == "ROS2-W"
    _same(a, b)


def _coupled_gains(seed: int = 7) -> list[np.ndarray]:
    """The book's 4th-order gains with off-diagonal terms: a dense Phi, Gamma."""
    rng = np.random.default_rng(seed)
    v = (22.9778, 357.2853, 1831.5, 5737.7)
    return [vi * (np.eye(3) + 0.03 * rng.normal(size=(3, 3))) for vi in v]


@pytest.mark.parametrize("hold", ["start", "end", "trapezoid"])
@pytest.mark.parametrize("coupled", [False, True])
def test_observer_holds_and_coupled_gains_equal_python_loop(hold, coupled):
    """The loop hands the observer the F, G it evaluated for the law (at the previous sample
    for "start"/"trapezoid"); dense (coupled) and channel-decoupled Phi alike."""
    from mwip.laws.smc.controller import SlidingModeController, SMCGains
    from mwip.laws.switching import Switching
    from mwip.observers.design import published_gain_sets

    gains = _coupled_gains() if coupled else published_gain_sets()["do4"].gains
    out = []
    for compiled in (True, False):
        obs = HighOrderDO(NOMINAL, gains, 0.002, model_hold=hold)
        assert (np.count_nonzero(obs.Phi) > 48) == coupled
        ctrl = SlidingModeController(SMCGains((3.0, 0.01, 0.1, 3.0), 6.3, 4.0), obs, NOMINAL,
                                     0.002, Switching("sat", 0.05), check=False)  # fmt: skip
        out.append(simulate(ctrl, REAL, q0=(0.1, 0.15, 0.2), qdot0=(0.5, 0.0, 0.3),
                            duration=0.6, disturbance=Sinusoid(amplitude=(0.1, 0.2, 0.05)),
                            compiled=compiled))  # fmt: skip
    assert np.abs(out[0].logs["tau_hat"][-1]).max() > 1e-3  # the observer is at work
    _same(*out)


def test_single_run_that_falls_is_truncated_alike():
    a, b = _pair("lqr", REAL, q0=(0.0, 1.5, 0.0), qdot0=(0.0, 5.0, 0.0), duration=2.0)
    assert a.status[0] == "fell"
    _same(a, b)


def test_parallel_batch_equals_serial_single_runs():
    """The threaded loop (N >= PARALLEL_MIN) gives each robot the result of its own run."""
    q0 = np.zeros((70, 3))
    q0[:, 1] = np.linspace(-0.2, 0.2, 70)
    ctrl = registry.build("hodosmc", NOMINAL)
    batch = simulate(ctrl, REAL, q0=q0, duration=0.5)
    for i in (0, 33, 69):
        one = simulate(registry.build("hodosmc", NOMINAL), REAL, q0=q0[i], duration=0.5)
        np.testing.assert_array_equal(batch.states[i], one.states[0])


def test_falls_back_to_python_loop_and_compiled_true_refuses():
    from mwip.observers.first_order import FirstOrderDO  # noqa: F401  (not compiled)
    from mwip.sim.sensors import IdealSensor

    class Noisy(IdealSensor):
        pass

    ctrl = registry.build("lqr", NOMINAL)
    res = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=0.1, sensor=Noisy())
    assert res.settings["compiled"] is False
    with pytest.raises(ValueError, match="compiled=True"):
        simulate(ctrl, REAL, duration=0.1, sensor=Noisy(), compiled=True)
    from mwip.fuzzy.pdc import BOOK_G1, BOOK_G2, PDCBalance

    pdc = PDCBalance(np.array([BOOK_G1, BOOK_G2]) * 1e-3)  # no compiled law: the Python loop
    assert simulate(pdc, REAL, duration=0.1).settings["compiled"] is False


def test_observer_update_equals_its_numpy_form():
    """HighOrderDO.update delegates to the compiled kernel; the NumPy form of the module
    docstring, d = (q'_{k+1} - q'_k) / Ts - (F + G u) and z <- Phi z + Gamma d, agrees."""
    from mwip.models.reduced import f_g

    rng = np.random.default_rng(3)
    book = [22.9778, 357.2853, 1831.5, 5737.7]
    for hold, gains in [(h, g) for h in ("start", "end", "trapezoid")
                        for g in (book, _coupled_gains())]:  # fmt: skip
        obs = HighOrderDO(NOMINAL, gains, 0.005, model_hold=hold)
        q0, qd0 = rng.normal(size=(4, 3)) * 0.2, rng.normal(size=(4, 3))
        obs.reset(qd0, q0=q0)
        z = np.zeros((4, 12))
        qp, qdp = q0, qd0
        for _ in range(5):
            q, qd, u = (
                rng.normal(size=(4, 3)) * 0.2,
                rng.normal(size=(4, 3)),
                rng.normal(size=(4, 2)),
            )
            uAB = np.stack([u[:, 0] + u[:, 1], u[:, 0] - u[:, 1]], axis=1)

            F0, G0 = f_g(NOMINAL, qp, qdp)
            F1, G1 = f_g(NOMINAL, q, qd)
            start = F0 + np.einsum("nij,nj->ni", G0, uAB)
            end = F1 + np.einsum("nij,nj->ni", G1, uAB)
            f = {"start": start, "end": end, "trapezoid": 0.5 * (start + end)}[hold]
            d = (qd - qdp) / 0.005 - f
            z = z @ obs.Phi.T + d @ obs.Gamma.T
            qp, qdp = q, qd
            np.testing.assert_allclose(obs.update(q, qd, u), z[:, :3], rtol=1e-11, atol=1e-9)


def test_a_subclass_that_changes_the_python_calls_runs_the_python_loop():
    """A subclass overriding log/__call__/reset below the class that defines packed_law
    runs what it overrides (the Python loop); one that only changes its data (``__init__``)
    keeps the compiled loop, which reads that data."""
    import numpy as np

    from mwip.laws.asta.controller import ASMC
    from mwip.laws.lqr.controller import LQR, design_lqr
    from mwip.params import NOMINAL, REAL
    from mwip.sim import simulate

    class Logged(LQR):
        def log(self):
            return {"extra": np.ones((1, 1))}

    class NoSTA(ASMC):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.K = np.zeros(2)

    d = design_lqr(NOMINAL, Ts=0.005)
    assert simulate(LQR(d), REAL, q0=(0, 0.1, 0), duration=0.1).settings["compiled"]
    res = simulate(Logged(d), REAL, q0=(0, 0.1, 0), duration=0.1)
    assert not res.settings["compiled"] and "extra" in res.logs
    kw = dict(q0=(0, 0.1, 0), duration=0.5, Ts=0.0005, dt=0.0005)
    a = simulate(NoSTA(NOMINAL, Ts=0.0005), REAL, **kw)
    b = simulate(NoSTA(NOMINAL, Ts=0.0005), REAL, compiled=False, **kw)
    assert a.settings["compiled"] and np.array_equal(a.states, b.states)
    c = simulate(ASMC(NOMINAL, Ts=0.0005), REAL, **kw)
    assert not np.array_equal(a.states, c.states)  # K = 0 is another law


FUZZY_TARGETS = ({}, {"p_d": 0.4}, {"alpha_d": -0.6}, {"p_d": -0.3, "alpha_d": 0.8})


@pytest.mark.parametrize("name", ["it2", "t1"])
@pytest.mark.parametrize("targets", FUZZY_TARGETS, ids=lambda s: "-".join(s) or "none")
def test_fuzzy_5ms_runs_equal_python_loop(name, targets):
    """Fig. 5.3 (IT2 and type 1) at 5 ms with and without position / heading targets: a
    single run on the default robot and a batch with varied parameters (one robot falls),
    bit for bit (both loops call laws.fig53.kernel.fig53_law); the targets are reached."""
    spec = registry.get(name)
    kw = dict(q0=(0.0, 0.1, 0.2), qdot0=(0.5, 0.0, 0.0), duration=5.0)
    a, b = (simulate(spec.build(NOMINAL, targets, Ts=0.005), REAL, compiled=c, **kw)
            for c in (True, False))  # fmt: skip
    assert a.settings["integrator"] == "RK4" and a.status[0] == "ok"
    assert list(a.logs) == ["theta_off", "u_alpha"]
    _same_bits(a, b)
    if "alpha_d" in targets:  # the heading moves towards its target
        assert abs(a.alpha[-1] - targets["alpha_d"]) < abs(0.2 - targets["alpha_d"])
    else:
        assert not np.any(a.logs["u_alpha"])
    if "p_d" not in targets:
        assert not np.any(a.logs["theta_off"])
    rng = np.random.default_rng(5)
    plants = [replace(REAL, mb=REAL.mb * f, l=REAL.l * g, r=REAL.r * h)
              for f, g, h in 1 + 0.2 * rng.uniform(-1, 1, (6, 3))]  # fmt: skip
    q0 = np.zeros((6, 3))
    q0[:, 1] = [0.05, -0.1, 0.15, 0.0, 0.08, 1.4]
    qd0 = np.zeros((6, 3))
    qd0[5, 1] = 10.0
    kw = dict(q0=q0, qdot0=qd0, duration=5.0, record_every=3)
    a, b = (simulate(spec.build(NOMINAL, targets, Ts=0.005), stack_params(plants), compiled=c,
                     **kw) for c in (True, False))  # fmt: skip
    assert list(a.status[:5]) == ["ok"] * 5 and a.status[5] == "fell"
    _same_bits(a, b)


def test_fuzzy_rows_batch_and_parallel_loop_equal_python_loop():
    """A Fig53Controller with one row per robot (kinds, gains and targets differ), run on
    the threaded loop (N >= PARALLEL_MIN): each robot gets its row, as in the Python loop."""
    from mwip.fuzzy.pdc import design_pdc
    from mwip.laws.fig53.controller import Fig53Controller
    from mwip.sim.loop import PARALLEL_MIN

    n = PARALLEL_MIN + 2
    d = design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL)
    rng = np.random.default_rng(2)
    designs = [replace(d, G=d.G * rng.uniform(0.9, 1.1, (2, 4))) for _ in range(n)]
    kinds = ["it2" if i % 3 else "t1" for i in range(n)]
    p_d = [None if i % 4 == 0 else float(v) for i, v in enumerate(rng.uniform(-1, 1, n))]
    a_d = [None if i % 5 == 0 else float(v) for i, v in enumerate(rng.uniform(-1, 1, n))]
    q0 = np.zeros((n, 3))
    q0[:, 1] = rng.uniform(-0.15, 0.15, n)

    def ctrl():
        return Fig53Controller(designs, kinds, p_d, a_d, params=NOMINAL, Ts=0.005)

    a, b = (simulate(ctrl(), REAL, q0=q0, duration=1.0, compiled=c) for c in (True, False))
    _same_bits(a, b)
    one = simulate(Fig53Controller([designs[7]], [kinds[7]], [p_d[7]], [a_d[7]]), REAL,
                   q0=q0[7], duration=1.0)  # fmt: skip
    np.testing.assert_array_equal(one.states[0], a.states[7])
    with pytest.raises(ValueError, match=f"{n} rows, the batch 3"):
        simulate(ctrl(), REAL, q0=q0[:3], duration=0.1)


def _same_bits(a, b):
    """Equal runs, bit for bit (``_same`` allows round-off; these need none)."""
    _same(a, b)
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.inputs, b.inputs)
    for k in a.logs:
        np.testing.assert_array_equal(a.logs[k], b.logs[k])
