"""The compiled closed loop (mwip.sim.loop) equals the Python loop of the engine.

Both call the same compiled law kernels with the same arguments in the same order, so a run
must agree to round-off (here: exactly, bit for bit, on this machine; the tolerance allows a
few ulps should a compiler reorder a sum).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip.control import registry
from mwip.observers import HighOrderDO
from mwip.params import NOMINAL, REAL, REAL_LITERAL, stack_params
from mwip.sim import Sinusoid, simulate

COMPILED = ("lqr", "dlqr", "smc", "do1smc", "hodosmc", "tsmc", "asta", "asmc")


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
    it2 = registry.build("it2", NOMINAL)  # no compiled law (yet): the Python loop
    assert simulate(it2, REAL, duration=0.1).settings["compiled"] is False


def test_observer_update_equals_its_numpy_form():
    """HighOrderDO.update delegates to the compiled kernel; the NumPy form of the module
    docstring, d = (q'_{k+1} - q'_k) / Ts - (F + G u) and z <- Phi z + Gamma d, agrees."""
    from mwip.models.reduced import f_g

    rng = np.random.default_rng(3)
    gains = [22.9778, 357.2853, 1831.5, 5737.7]
    for hold in ("start", "end", "trapezoid"):
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
