"""The twin's compiled loop (mwip.hardware.loop) against the NumPy oracles of its elements.

A batch of twins that differ per robot (their unknowns and their element sets), with IMU noise
and a disturbance, runs through the compiled twin loop (the default when the controller has a
packed law), through the engine's Python loop on the same compiled element chains
(``compiled=False``: :class:`~mwip.hardware.twin.TwinSensor` / ``TwinActuator`` stepping the
chains for the batch at each sample) and through the Python loop on the NumPy oracles of the
elements (tests/oracle_twin.py, written apart from the kernels).

The two compiled paths run the same compiled arithmetic in the same order: they must agree bit
for bit. The oracle must agree with them to round-off: the one operation of the sensor whose
oracle is not the kernel's is the accelerometer tilt ``arctan2`` (NumPy's SIMD loop and the C
library's ``atan2`` may differ in the last bit for about 0.1 % of arguments), which moves the
fused pitch by ulps; the PWM quantisation absorbs that before it reaches the torque, so the
plant states stay identical; the law's own state (the high-gain disturbance observer's
``tau_hat``) carries the ulps, amplified by its gains (a few 1e-10 N m over a 256-robot, 10 s
batch). Tolerance 1e-9, absolute and relative: far below any physical quantity, far above what
an ulp of the tilt becomes over these runs.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip.hardware.drivetrain import relative_mobility
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.fusion import FusionSpec
from mwip.hardware.identified import default_twin
from mwip.laws.batch import batch
from mwip.laws.registry import build
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate
from mwip.sim.disturbance import Sinusoid
from oracle_twin import OracleActuator, OracleSensor

TOL = 1e-9
N = 6
NAMES = ("drive.gear_ratio", "firmware.emf_compensation", "drive.deadband",
         "drive.current_limit", "gearbox.coulomb", "gearbox.backlash", "firmware.delay",
         "imu.gyro_bias", "imu.accel_sigma", "imu.gyro_sigma", "imu.height",
         "firmware.fusion.tau")  # fmt: skip


def _values(twin, n: int = N) -> dict[str, np.ndarray]:  # noqa: ANN001
    rng = np.random.default_rng(11)
    out = {k: twin.prior[k].low + rng.random(n) * (twin.prior[k].high - twin.prior[k].low)
           for k in NAMES}  # fmt: skip
    # the firmware's torque gain per robot too (near 1: the robots stand a while)
    out["firmware.torque_gain"] = np.linspace(0.8, 1.25, n)
    return out


def _rows() -> list[list[str]]:
    every = list(ELEMENTS)
    return [every, [e for e in every if e != "encoder"], [e for e in every if e != "fusion"],
            [e for e in every if e not in ("motor", "pwm", "sag")],
            [e for e in every if e not in ("backlash", "friction", "delay")],
            [e for e in every if e not in ("imu_noise", "sag")]]  # fmt: skip


def _chains(tw, p, rows, vals, common, oracle):  # noqa: ANN001, ANN202
    """The twin's sensor and drive: the compiled chains, or the NumPy oracles."""
    if not oracle:
        return (tw.sensor(p, rows, common_noise=common, values=vals),
                tw.actuator(p, rows, vals))  # fmt: skip
    masks = tw.masks(rows)
    sensor = OracleSensor(p, tw, masks=masks, common_noise=common, values=vals)
    act = OracleActuator(tw, plant_b_over_r=float(np.mean(p.b / p.r)), masks=masks,
                         mobility=relative_mobility(p), values=vals)  # fmt: skip
    return sensor, act


def _run(ctrl_factory, compiled, *, twin=None, rows=None, values=None, common=False,  # noqa: ANN001, ANN202
         seed=3, duration=2.0, dist=True, oracle=False):  # fmt: skip
    """``compiled``: None (the compiled twin loop) or False (the Python loop); ``oracle``:
    the Python loop on the NumPy oracles."""
    tw = default_twin() if twin is None else twin
    vals = tw.row_values(values)[0] if values is not None else None
    base = REAL.with_payload(0.3, 0.05) if rows is None else REAL
    p = tw.plant(base, rows, vals)
    if p.batch_shape == ():
        p = replace(p, Db=np.full(N, float(p.Db)))
    sensor, act = _chains(tw, p, rows, vals, common, oracle)
    q0 = np.column_stack([np.zeros(N), np.linspace(-0.15, 0.15, N), np.zeros(N)])
    d = Sinusoid(amplitude=(0.3, 0.2, 0.05), omega=(3.0, 5.0, 2.0)) if dist else None
    return simulate(ctrl_factory(), p, q0=q0, duration=duration, Ts=tw.Ts, dt=tw.dt,
                    disturbance=d, sensor=sensor, actuator=act, seed=seed, record_every=3,
                    compiled=False if oracle else compiled)  # fmt: skip


def _hodosmc():  # noqa: ANN202
    return build("hodosmc", NOMINAL, {})


def _close(a, b) -> None:  # noqa: ANN001
    """``a`` (a Python loop: the oracle's or the compiled chains') and ``b`` (the compiled
    twin loop) agree to :data:`TOL`."""
    assert a.settings["compiled"] is False and b.settings["compiled"] is True
    assert list(a.status) == list(b.status)
    np.testing.assert_array_equal(a.t_end, b.t_end)
    assert sorted(a.logs) == sorted(b.logs) and "u_applied" in b.logs
    np.testing.assert_allclose(b.states, a.states, rtol=0, atol=TOL)
    np.testing.assert_allclose(b.inputs, a.inputs, rtol=TOL, atol=TOL)
    for k in a.logs:
        np.testing.assert_allclose(b.logs[k], a.logs[k], rtol=TOL, atol=TOL, err_msg=k)
    np.testing.assert_array_equal(np.isnan(a.states), np.isnan(b.states))


def _same(a, b) -> None:  # noqa: ANN001
    """The Python loop on the compiled chains ``a`` and the compiled twin loop ``b``: the
    same compiled arithmetic in the same order, bit for bit."""
    assert a.settings["compiled"] is False and b.settings["compiled"] is True
    assert list(a.status) == list(b.status)
    np.testing.assert_array_equal(a.t_end, b.t_end)
    assert sorted(a.logs) == sorted(b.logs)
    np.testing.assert_array_equal(b.states, a.states)
    np.testing.assert_array_equal(b.inputs, a.inputs)
    for k in a.logs:
        np.testing.assert_array_equal(b.logs[k], a.logs[k], err_msg=k)


@pytest.mark.parametrize("chunked", [False, True])
def test_per_robot_twins_with_noise_and_disturbance_match_the_oracle(
    chunked: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``chunked``: the compiled loop takes the disturbance and the noise 16 samples at a
    time (what a long run or a large batch does) and must give the same run."""
    from mwip.hardware import loop

    if chunked:
        monkeypatch.setattr(loop, "CHUNK_NUMBERS", 1000)
    tw = default_twin()
    vals = _values(tw)
    o = _run(_hodosmc, False, values=vals, rows=_rows(), oracle=True)
    a = _run(_hodosmc, False, values=vals, rows=_rows())
    b = _run(_hodosmc, None, values=vals, rows=_rows())
    _close(o, b)
    _same(a, b)
    assert np.nanstd(o.logs["u_applied"][:, 1:] - o.inputs[:, 1:]) > 1e-3  # the drive acts


def test_one_setting_per_robot_common_noise_and_a_fall_match() -> None:
    """PackedController (one parameter vector per robot), common noise, the payload plant,
    one robot started past recovery (it falls: recorded up to its stop, then NaN)."""
    settings = [{"K": (6.3 * f, 4.0)} for f in (0.6, 0.8, 1.0, 1.2, 1.4, 1.6)]

    def ctrl():  # noqa: ANN202
        return batch("hodosmc", settings, NOMINAL, Ts=0.005)

    def run(compiled, oracle=False):  # noqa: ANN001, ANN202
        tw = default_twin()
        p = tw.plant(REAL.with_payload(0.5, 0.1))
        p = replace(p, Db=np.full(N, float(p.Db)))
        sensor, act = _chains(tw, p, None, None, True, oracle)
        q0 = np.column_stack([np.zeros(N), [0.1, -0.1, 0.05, 1.2, 0.0, 0.2], np.zeros(N)])
        return simulate(ctrl(), p, q0=q0, duration=1.5, Ts=tw.Ts, dt=tw.dt,
                        sensor=sensor, actuator=act,
                        disturbance=Sinusoid(amplitude=(0.2, 0.0, 0.0)), seed=8,
                        compiled=compiled)  # fmt: skip

    o, a, b = run(False, oracle=True), run(False), run(None)
    assert "fell" in list(o.status)
    _close(o, b)
    _same(a, b)


def test_the_fast_path_is_deterministic_and_follows_the_seed() -> None:
    vals = _values(default_twin())
    a = _run(_hodosmc, None, values=vals, seed=5, duration=1.0)
    b = _run(_hodosmc, None, values=vals, seed=5, duration=1.0)
    c = _run(_hodosmc, None, values=vals, seed=6, duration=1.0)
    assert np.array_equal(a.states, b.states, equal_nan=True)
    assert np.array_equal(a.inputs, b.inputs, equal_nan=True)
    assert not np.array_equal(a.inputs, c.inputs, equal_nan=True)


def test_a_kalman_twin_runs_compiled_and_matches_the_oracle() -> None:
    """The Kalman fusion is a compiled element like the complementary one (it once kept the
    Python loop): the compiled twin loop runs it and equals the oracle's filter."""
    tw0 = default_twin()
    tw = replace(tw0, firmware=replace(tw0.firmware, fusion=FusionSpec(kind="kalman")))
    o = _run(_hodosmc, False, twin=tw, duration=1.0, dist=False, oracle=True)
    a = _run(_hodosmc, False, twin=tw, duration=1.0, dist=False)
    b = _run(_hodosmc, True, twin=tw, duration=1.0, dist=False)
    _close(o, b)
    _same(a, b)
    # and the filter is the Kalman one: not the complementary twin's run
    c = _run(_hodosmc, True, twin=tw0, duration=1.0, dist=False)
    assert not np.array_equal(c.inputs, b.inputs, equal_nan=True)


def test_a_campaign_block_on_the_twin_matches_the_python_loop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The tuner's path (mwip.campaign.blocks.run_block on the twin): the campaign's
    per-sample disturbance is tabulated by its distinct columns (none, the book's sinusoids),
    robot i reading its own; the same runs as the Python loop's per-robot table."""
    import mwip.sim.engine as engine
    from mwip.campaign.blocks import _disturbance, draw, run_block
    from mwip.campaign.spec import ControllerEntry
    from mwip.laws.registry import get
    from mwip.tune.evaluate import robot_set

    rs = robot_set("robustness", 8, 8, 2026, plant="twin", duration=1.0)
    camp = replace(rs.campaign, controllers=(ControllerEntry("hodosmc", "hodosmc", ()),))
    labels = draw(camp, np.arange(8))["disturbance"]
    dist = _disturbance(camp, labels)
    assert dist is not None and len(set(dist.column_of.tolist())) == 2  # both kinds present
    spec = get("hodosmc")
    ctrl = spec.build(camp.design, spec.resolve({}))
    got = {}
    orig = engine.simulate
    for compiled in (False, None):

        def sim(*a, _c=compiled, **k):  # noqa: ANN002, ANN003, ANN202
            got[_c] = orig(*a, compiled=_c, **k)
            return got[_c]

        monkeypatch.setattr(engine, "simulate", sim)
        run_block(camp, 0, {"hodosmc": ctrl})
    _close(got[False], got[None])


@pytest.mark.parametrize("case", [1, 3])
def test_run_on_twin_without_drive_logs_runs_compiled_and_records_the_measurement(
    case: int,
) -> None:
    """``run_on_twin(..., drive_logs=False)`` (the book calibration's runs) records in the
    compiled twin loop the measurement the law read: ``y_meas`` and the law's logs equal the
    run with the drive's logs (``drive_logs=True``) to round-off, over a batch of twins with
    different unknowns and, in Case 3, the stick."""
    from mwip.hardware.twin import run_on_twin
    from mwip.studies.exp_hodosmc import make_controller
    from mwip.studies.twin_settings import study_settings

    tw = default_twin()
    cfg = dict(study_settings("exp-hodosmc-obstacle" if case == 3 else "exp-hodosmc-balance",
                              None, tw)[0])  # fmt: skip
    values = {"drive.deadband": np.array([0.0, 0.002, 0.004]),
              "imu.gyro_sigma": np.array([0.001, 0.002, 0.004])}  # fmt: skip
    runs = {}
    for logs in (False, True):
        ctrl = make_controller("do1smc", cfg, -7.0 if case == 3 else 0.0, NOMINAL)
        runs[logs] = run_on_twin(ctrl, case, twin=tw, values=values, duration=2.0,
                                 q0=np.tile([0.0, 0.05, 0.0], (3, 1)), drive_logs=logs)
    fast, slow = runs[False], runs[True]
    # both run compiled now (the compiled loop records the elements' logs too)
    assert fast.settings["compiled"] is True and slow.settings["compiled"] is True
    assert "drive_duty" in slow.series() and "drive_duty" not in fast.series()
    assert list(fast.status) == list(slow.status)
    ym_f, ym_s = fast.series()["y_meas"], slow.series()["y_meas"]
    assert ym_f.shape == ym_s.shape and np.isfinite(ym_f[:, :50]).all()
    np.testing.assert_allclose(ym_f, ym_s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.states, slow.states, rtol=0, atol=1e-9)
