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
    # with the twin's elements off the speed target is tracked: last 2 s near -2 rad/s
    from mwip.hardware.twin import Twin

    res = twin.with_overrides(twin_config=Twin(elements=frozenset())).run()
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
