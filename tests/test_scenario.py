"""Scenarios as TOML data."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.params import NOMINAL, REAL
from mwip.scenario import Scenario, load_scenario
from mwip.sim import BOOK_SINUSOIDS

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_examples_load_and_run():
    sc = load_scenario(EXAMPLES / "balance.toml")
    assert sc.plant == REAL and sc.design == NOMINAL and sc.disturbance == BOOK_SINUSOIDS
    assert sc.initial == {"theta": 0.1745}
    heavy = load_scenario(EXAMPLES / "heavy_robot.toml")
    assert heavy.plant == replace(REAL, mb=3.2, l=0.07)
    res = heavy.with_overrides(duration=2.0).run()
    assert res.ok and res.q_dot[0, 0] == pytest.approx(0.3 / REAL.r)
    twin = load_scenario(EXAMPLES / "hodosmc_twin.toml")
    assert twin.controller == "hodosmc" and twin.twin and twin.settings["K"] == [6.3, 4.0]
    res = twin.run()
    assert "imu_gyro" in res.logs  # ran through the twin's sensors (default twin: it may fall)
    # with the twin's elements off the speed target is tracked: last 2 s near -2 rad/s (the
    # twin is the robot's: Scenario.robot, the robot file's)
    from mwip.hardware.twin import Twin
    from mwip.robot import Robot

    res = twin.with_overrides(robot=Robot(twin=Twin(elements=frozenset()))).run()
    assert res.ok
    tail = res.t >= res.t[-1] - 2.0
    assert abs(np.mean(res.q_dot[tail, 0]) + 2.0) < 0.5


def test_scenario_matches_direct_simulation():
    from mwip.laws.lqr.controller import LQR, design_lqr
    from mwip.sim import simulate

    sc = Scenario(duration=1.0, initial={"theta": 0.1, "alpha": 0.2})
    a = sc.run()
    b = simulate(LQR(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0, 0.1, 0.2), duration=1.0)
    np.testing.assert_array_equal(a.states, b.states)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[scenario]\nduration = -1\n", "[scenario] duration"),
        ("[scenario]\ncontroler = 'lqr'\n", "unknown key 'controler'"),
        ("[scenario]\ncontroller = 'pid'\n", "unknown controller 'pid'; choose from: lqr"),
        ("[plant]\nmb = 0\n", "[plant] parameter 'mb'"),
        ("[plant]\nmass = 2\n", "[plant] unknown parameter 'mass'"),
        ("[initial]\ntheta = 2.0\n", "[initial] theta"),
        ("[initial]\nphi = 2.0\n", "unknown key 'phi'"),
        ("[wind]\nspeed = 2.0\n", "unknown table [wind]"),
        ("[disturbance]\nkind = 'gust'\n", "[disturbance]"),
        ("[scenario\n", "not valid TOML"),
    ],
)
def test_bad_scenarios_are_one_line_errors(tmp_path, capsys, text, needle):
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as exc:
        load_scenario(path)
    assert needle in str(exc.value) and "\n" not in str(exc.value)
    assert main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err
    assert not (tmp_path / "o").exists()


def test_cli_options_override_scenario(tmp_path, capsys):
    out = tmp_path / "o"
    code = main(["simulate", "--scenario", str(EXAMPLES / "balance.toml"), "--duration", "2",
                 "--theta0", "0.05", "--json", "--out", str(out)])  # fmt: skip
    assert code == 0
    data = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
    assert data["t"][-1] == pytest.approx(2.0) and data["theta"][0] == pytest.approx(0.05)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--theta0", "2"], "--theta0: must be in (-1.5708, 1.5708) rad, got 2.0"),
        (["--theta0", "-1.5707963267948966"], "--theta0: must be in (-1.5708, 1.5708) rad"),
        (["--duration", "0"], "--duration: must be in (0, 3600], got 0.0"),
        (["--Ts", "inf"], "--Ts': must be a finite number, got inf"),  # (every command)
        (["--dt", "0.01"], "--dt: must be in (0, 0.005], got 0.01"),
        (["--Ts", "0.002", "--dt", "0.004"], "--dt: must be in (0, 0.002], got 0.004"),
        (["--v0", "-1000"], "--v0: must be in (-1000, 1000], got -1000.0"),
        (["--alpha0", "nan"], "--alpha0': must be a finite number, got nan"),
        (["--controller", "pid"], "--controller: unknown controller 'pid'; choose from: lqr"),
        (["--set", "phi=1"], "--set: controller 'lqr' has no setting 'phi'"),
        (["--controller", "smc", "--set", "phi=-1"], "--set: controller 'smc': setting 'phi'"),
        (["--case", "2"], "error: [scenario] case = 2 runs on the digital twin"),
    ],
)
def test_a_refused_option_is_named_by_the_scenario(argv, message, tmp_path, capsys):
    """The scenario validates every field once; the CLI names the option the value came from
    (and a field the scenario file set, the file's table and key)."""
    assert main(["simulate", *argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o").exists()


def test_a_refused_field_of_the_file_is_named_by_its_table(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text("[scenario]\nTs = 0.01\ndt = 0.004\n")
    assert main(["simulate", "--scenario", str(path), "--duration", "9000"]) == 2
    err = capsys.readouterr().err
    assert "Invalid value for --duration: must be in (0, 3600], got 9000.0" in err
    # --Ts makes the file's dt too long: the file's field is named, not --dt
    assert main(["simulate", "--scenario", str(path), "--Ts", "0.002"]) == 2
    assert "mwip: error: [scenario] dt must be in (0, 0.002], got 0.004" in capsys.readouterr().err
