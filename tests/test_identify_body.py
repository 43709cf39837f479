"""The body stage (mwip.identify.body): the lumped coefficients of (2.32) from balancing rows."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.hardware.twin import run_on_twin
from mwip.identify import synth
from mwip.identify.body import LUMPED, body_stage, lumped_of
from mwip.identify.fit import fit
from mwip.identify.logs import Log
from mwip.laws.registry import build
from mwip.robot import load_robot


@pytest.fixture(scope="module")
def setup():  # type: ignore[no-untyped-def]
    # a fixed robot, the book calibration's earlier twin of record (tests/data/), so that the
    # synthetic truth does not move with the default robot's calibration; the default twin
    # of revision 9 has 20 times its Coulomb friction, which the body fit does not model
    # (issue 38's closing note: m22 then comes out 5.8 % low)
    r = load_robot(Path(__file__).parent / "data" / "record_robot.toml")
    body = replace(r.body, l=1.15 * r.body.l, mb=1.1 * r.body.mb)  # l +15 %, mb +10 %
    ctrl = build("lqr", r.design, {}, Ts=r.Ts)
    return r, body, ctrl


def _log(r, cols, n, theta, rate, enc):  # type: ignore[no-untyped-def]
    cc = {"t": np.arange(n) * r.Ts, "theta": theta[:n], "theta_rate": rate[:n],
          "enc_r": enc[:n], "enc_l": enc[:n], "u_r": cols["u_r"][:n], "u_l": cols["u_l"][:n]}
    return Log("synthetic", "0", cc, np.full(n, "balancing"), "torque")


def test_true_states_recover_changed_body(setup) -> None:  # type: ignore[no-untyped-def]
    """True states, the logged command through the drive chain: every true coefficient of
    the changed body inside its interval, the book's (Table 6.1) m12, m22, Gb outside."""
    r, body, ctrl = setup
    q0 = (0.0, 0.25, 0.0)
    res = run_on_twin(ctrl, twin=r.twin, q0=q0, duration=5.0, record_every=1, seed=0,
                      plant=body)
    q = np.asarray(res.q)
    q = q[0] if q.ndim == 3 else q
    qd = np.asarray(res.qdot)
    qd = qd[0] if qd.ndim == 3 else qd
    cols = synth.balancing_log_on(r.twin, body, ctrl, 5.0, 0, q0=q0)
    n = min(len(q), len(cols["t"]))
    lg = _log(r, cols, n, q[:, 1], qd[:, 1], q[:, 0] - q[:, 1])
    out = body_stage([lg], r.twin, r.body, {"imu.gyro_bias": 0.0})
    true = lumped_of(r.twin.plant(body))
    book = lumped_of(r.twin.plant(r.body))
    for i, name in enumerate(LUMPED):
        lo, hi = out.interval[name]
        assert out.identifiable[name], name
        assert lo <= true[i] <= hi, (name, true[i], lo, hi)
        assert abs(out.estimate[name] / true[i] - 1.0) < 0.05, name
    for name in ("m12", "m22", "Gb"):
        i = LUMPED.index(name)
        assert not (out.interval[name][0] <= book[i] <= out.interval[name][1]), name
        assert name in out.file_outside()


def test_little_motion_not_identified(setup) -> None:  # type: ignore[no-untyped-def]
    """The logged sensors from a 0.05 rad lean: the pitch barely moves; m12, m22 are reported
    not identified (relative standard error above the threshold), and fit() carries the
    result into fit.json."""
    r, body, ctrl = setup
    cols = synth.balancing_log_on(r.twin, body, ctrl, 5.0, 0, q0=(0.0, 0.05, 0.0))
    n = len(cols["t"])
    lg = _log(r, cols, n, cols["theta"], cols["theta_rate"], cols["enc_r"])
    result = fit([lg], r.twin, body=r.body)
    out = result.body
    assert out is not None
    assert not out.identifiable["m12"] and not out.identifiable["m22"]
    assert "not identified: " in out.summary()
    assert any("body: m12 is not identified" in f for f in result.flags)
    js = json.loads(json.dumps(result.to_json()))
    assert js["body"]["lumped"]["m12"]["identifiable"] is False
    assert set(js["body"]["lumped"]) == set(LUMPED)


#: Declared before these seeds ran (development: seeds 1-4, mwip.identify.body's BIAS
#: docstring): a 10 s log under lqr with a dither of 0.05 N m, seeds 5-8.
DITHER_SEEDS = range(5, 9)


@pytest.fixture(scope="module")
def dithered(setup):  # type: ignore[no-untyped-def]
    from mwip.identify.dither import Dithered

    r, body, _ = setup
    logs = []
    for seed in DITHER_SEEDS:
        ctrl = Dithered(build("lqr", r.design, {}, Ts=r.Ts), 0.05, r.Ts, 10.0, seed=seed)
        cols = synth.balancing_log_on(r.twin, body, ctrl, 10.0, seed, q0=(0.0, 0.05, 0.0))
        n = len(cols["t"])
        logs.append(_log(r, cols, n, cols["theta"], cols["theta_rate"], cols["enc_r"]))
    return logs


def test_a_dither_identifies_the_body_and_tells_a_wrong_file(setup, dithered) -> None:  # type: ignore[no-untyped-def]
    """Closed-loop identification with a known signal added to the command (issue 37, item
    2): from the logged sensors every coefficient is identified; the inertial and gravity
    ones are within the method's declared bias (BIAS) of the truth; a robot file with the
    true body is not said to disagree, the book's body (l and mb smaller) is, in m12, m22
    and Gb."""
    from mwip.identify.body import BIAS, COMPARED

    r, body, _ = setup
    true = lumped_of(r.twin.plant(body))
    for lg in dithered:
        right = body_stage([lg], r.twin, body, {})
        assert all(right.identifiable[n] for n in LUMPED), right.summary()
        for i, n in enumerate(LUMPED):
            if n in COMPARED:
                assert abs(right.estimate[n] / true[i] - 1.0) <= BIAS, (n, right.summary())
        assert right.file_outside() == [], right.summary()
        wrong = body_stage([lg], r.twin, r.body, {})
        assert {"m12", "m22", "Gb"} <= set(wrong.file_outside()), wrong.summary()
        assert any("disagrees with the logs" in f for f in wrong.flags)


def test_the_dither_is_added_to_the_command_and_logged(setup) -> None:  # type: ignore[no-untyped-def]
    """The logged command is the controller's plus the dither: at the first sample (same
    state) the two runs differ by exactly d_0; the sequence is a function of its seed."""
    from mwip.identify.dither import Dithered, sequence

    r, body, ctrl = setup
    plain = synth.balancing_log_on(r.twin, body, build("lqr", r.design, {}, Ts=r.Ts), 0.2, 3)
    dctrl = Dithered(build("lqr", r.design, {}, Ts=r.Ts), 0.07, r.Ts, 0.2, seed=3)
    dith = synth.balancing_log_on(r.twin, body, dctrl, 0.2, 3)
    d = sequence(10, r.Ts, 0.07, seed=3)
    assert np.isclose(dith["u_r"][0] - plain["u_r"][0], d[0], rtol=0, atol=1e-12)
    assert np.isclose(dith["u_l"][0] - plain["u_l"][0], d[0], rtol=0, atol=1e-12)
    assert set(np.unique(np.abs(d))) == {0.07}
    assert np.array_equal(d, sequence(10, r.Ts, 0.07, seed=3))
    assert not np.array_equal(sequence(200, r.Ts, 0.07, seed=3), sequence(200, r.Ts, 0.07, seed=4))


def test_the_fitted_robot_takes_the_centre_of_mass_height(setup) -> None:  # type: ignore[no-untyped-def]
    """The user weighs the body (the file's mb is right); the logs give the centre of mass's
    height ``l = Gb / (mb g)`` (issue 37, item 2): on a body with l +15 % and Iyy +20 % (seeds
    5-8, declared with the tests above), l comes back within BIAS of the truth and replaces the
    file's in the fitted robot.toml, with its provenance; a field not precise enough (here
    Iyy, a small part of m22) keeps the file's value. Without a dither nothing is written."""
    from mwip.identify.body import BIAS
    from mwip.identify.dither import Dithered
    from mwip.identify.report import fitted_robot

    r, _, ctrl = setup
    true = replace(r.body, l=1.15 * r.body.l, Iby=1.2 * r.body.Iby)
    for seed in DITHER_SEEDS:
        dctrl = Dithered(build("lqr", r.design, {}, Ts=r.Ts), 0.05, r.Ts, 10.0, seed=seed)
        cols = synth.balancing_log_on(r.twin, true, dctrl, 10.0, seed, q0=(0.0, 0.05, 0.0))
        lg = _log(r, cols, len(cols["t"]), cols["theta"], cols["theta_rate"], cols["enc_r"])
        result = fit([lg], r.twin, body=r.body)
        assert result.body is not None and "l" in result.body.written(), result.body.fields
        robot = fitted_robot(result, [lg], r)
        assert abs(robot.body.l / true.l - 1.0) <= BIAS, (robot.body.l, true.l)
        assert "body stage" in robot.sources()["body.l"]
        if "Iyy" not in result.body.written():
            assert robot.body.Iby == r.body.Iby
    cols = synth.balancing_log_on(r.twin, true, ctrl, 5.0, 0, q0=(0.0, 0.25, 0.0))
    lg = _log(r, cols, len(cols["t"]), cols["theta"], cols["theta_rate"], cols["enc_r"])
    result = fit([lg], r.twin, body=r.body)
    assert result.body is not None and result.body.written() == {}
    assert fitted_robot(result, [lg], r).body == r.body
