"""``mwip twin calibrate FACTS --robot FILE``: a user's robot calibrated on what it did
(:mod:`mwip.calibration.robot_evidence`): synthetic truth comes back, a fact no twin can meet
rejects the structure, the robot changes the result, bad input is one line."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.robot import default_robot, load_robot, save_robot

#: the two unknowns left free (every other one fixed at the robot's value)
FREE = {"imu.gyro_bias": (-0.02, 0.02), "firmware.torque_gain": (0.25, 4.0)}
TRUTH = {"imu.gyro_bias": 0.012, "firmware.torque_gain": 1.0}

SCENARIO = """[scenario]
controller = "lqr"
duration = 6.0
Ts = 0.005
twin = true
case = 1
seed = 3

[initial]
theta = 0.1
"""


def _robot(mass: float | None = None) -> object:
    """A fixed robot (the book calibration's earlier twin of record, ``tests/data/
    record_robot.toml``, so that the synthetic truth does not move with the default robot's
    calibration) with a prior of two free unknowns; its own values of them are not the truth
    (the calibration must not read them)."""
    from mwip.robot import load_robot

    rb = load_robot(Path(__file__).parent / "data" / "record_robot.toml")
    tw = rb.twin
    unknowns = []
    for u in tw.prior.unknowns:
        if u.name in FREE:
            unknowns.append(replace(u, low=FREE[u.name][0], high=FREE[u.name][1]))
        else:
            v = float(tw.values()[u.name])
            unknowns.append(replace(u, low=v, high=v))
    from mwip.hardware.prior import Prior

    rb = replace(rb, name="test-bot", twin=replace(tw, prior=Prior(tuple(unknowns))))
    rb = rb.with_values({"imu.gyro_bias": -0.015, "firmware.torque_gain": 3.0})
    if mass is not None:
        rb = replace(rb, body=replace(rb.body, mb=mass), design=replace(rb.design, mb=mass))
    return rb


def _truth_rms(robot: object, folder: Path) -> tuple[bool, float]:
    """The truth's run, as one plain scenario run (not the calibration's batch path)."""
    from mwip.calibration.measured import measure
    from mwip.scenario import load_scenario

    truth = robot.with_values(TRUTH)  # type: ignore[attr-defined]
    sc = load_scenario(folder / "lqr.toml").with_overrides(robot=truth, plant=truth.body,
                                                           design=truth.design)  # fmt: skip
    res = sc.run()
    ok = res.status == "ok"
    y = res.series()["y_meas"]
    y = y if y.ndim == 3 else y[None]
    v = measure("rms_theta", res.t, y, np.atleast_1d(ok), window=(3.0, 6.0))
    return bool(np.all(ok)), float(v[0])


def _setup(tmp_path: Path, *, rms: float, extra: str = "", mass: float | None = None,
           draws: int = 100, search: int = 60) -> tuple[Path, Path]:  # fmt: skip
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "lqr.toml").write_text(SCENARIO)
    robot_file = tmp_path / "bot.toml"
    save_robot(_robot(mass), robot_file)  # type: ignore[arg-type]
    facts = tmp_path / "facts.toml"
    facts.write_text(f"""[evidence]
title = "test-bot on the bench"
[sample]
draws = {draws}
search_draws = {search}
seed = 5
block = 50
[[fact]]
scenario = "lqr.toml"
stands = true
source = "it stood"
[[fact]]
scenario = "lqr.toml"
metric = "rms_theta"
value = {rms!r}
tolerance = 1.15
window = [3.0, 6.0]
source = "the board's log"
{extra}""")
    return facts, robot_file


def _cli(*args: str) -> tuple[int, str]:
    from click.testing import CliRunner

    from mwip.cli import cli

    r = CliRunner().invoke(cli, ["twin", "calibrate", *args])
    return r.exit_code, r.output


def test_synthetic_truth_comes_back(tmp_path: Path) -> None:
    """Facts made by a known twin: the truth meets them, the prior meets them with a
    probability whose interval is above 0, the twins meeting them bracket the truth's gyro
    offset and identify it, and the calibrated robot file, run again, meets every fact."""
    robot = load_robot(_setup(tmp_path, rms=0.01)[1])
    stands, rms = _truth_rms(robot, tmp_path)
    assert stands and 0.005 < rms < 0.1
    facts, robot_file = _setup(tmp_path, rms=rms)
    code, text = _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))
    assert code == 0, text
    doc = json.loads((tmp_path / "o" / "calibration.json").read_text())
    s = doc["structure"]
    assert not s["rejected"] and s["evidence_95"][0] > 0 and doc["consistent"] >= 3
    g = doc["marginals"]["imu.gyro_bias"]
    assert g["q05"] <= TRUTH["imu.gyro_bias"] <= g["q95"] or (
        abs(g["q50"]) == pytest.approx(TRUTH["imu.gyro_bias"], rel=0.25))  # the sign: |offset|
    assert set(doc["marginals"]) == set(FREE)  # fixed unknowns are not described
    off = doc["offset"]  # what the rms pitch estimate pins: |gyro offset| x tau
    tau = robot.twin.values()["firmware.fusion.tau"]
    assert off["q05"] <= abs(TRUTH["imu.gyro_bias"]) * tau <= off["q95"]
    cal = load_robot(tmp_path / "o" / "robot.toml")
    member = doc["member"]["values"]
    assert cal.twin.values()["imu.gyro_bias"] == pytest.approx(member["imu.gyro_bias"])
    assert cal.body == robot.body
    from mwip.calibration.measured import measure
    from mwip.scenario import load_scenario

    sc = load_scenario(tmp_path / "lqr.toml").with_overrides(robot=cal, plant=cal.body,
                                                             design=cal.design)  # fmt: skip
    res = sc.run()
    y = res.series()["y_meas"]
    y = y if y.ndim == 3 else y[None]
    got = measure("rms_theta", res.t, y, np.atleast_1d(res.status == "ok"), window=(3.0, 6.0))
    assert np.all(res.status == "ok") and abs(np.log(got[0] / rms)) <= np.log(1.15)
    md = (tmp_path / "o" / "calibration.md").read_text()
    assert "test-bot on the bench" in md and "it stood" in md and "robot.toml" in md


def test_a_fact_no_twin_meets_rejects_the_structure(tmp_path: Path) -> None:
    """A standing run with 0.8 rad RMS pitch estimate: no twin of this prior makes it, so
    the structure is rejected by that fact and no robot file is written."""
    facts, robot_file = _setup(tmp_path, rms=0.8, draws=60, search=20)
    code, text = _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))
    assert code == 0, text
    doc = json.loads((tmp_path / "o" / "calibration.json").read_text())
    s = doc["structure"]
    assert s["rejected"] and s["rejected_by"] == ["num:lqr.rms_theta"]
    assert s["evidence"] == 0.0 and 0 < s["evidence_95"][1] < 0.1
    assert "member" not in doc and not (tmp_path / "o" / "robot.toml").exists()
    assert "rejected by num:lqr.rms_theta" in text and "No robot file" in text


def test_the_robot_changes_the_result_and_jobs_do_not(tmp_path: Path) -> None:
    """Another body mass in the robot file changes the twins' runs; two workers give the
    same bytes as one."""
    facts, robot_file = _setup(tmp_path / "a", rms=0.02, draws=40, search=0)
    assert _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "a1"))[0] == 0
    assert _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "a2"),
                "--jobs", "2")[0] == 0  # fmt: skip
    one = (tmp_path / "a1" / "calibration.json").read_bytes()
    assert (tmp_path / "a2" / "calibration.json").read_bytes() == one
    facts_b, robot_b = _setup(tmp_path / "b", rms=0.02, draws=40, search=0, mass=3.6)
    assert _cli(str(facts_b), "--robot", str(robot_b), "--out", str(tmp_path / "b1"))[0] == 0
    import pandas as pd

    ta = pd.read_parquet(tmp_path / "a1" / "draws.parquet")
    tb = pd.read_parquet(tmp_path / "b1" / "draws.parquet")
    assert np.allclose(ta.filter(like="u.").to_numpy(), tb.filter(like="u.").to_numpy())
    assert not np.allclose(ta["run0.t_end"].to_numpy(), tb["run0.t_end"].to_numpy()) or not (
        np.allclose(ta["fact1"].to_numpy(), tb["fact1"].to_numpy(), equal_nan=True))


def test_the_payload_of_the_robot_file_reaches_a_case2_scenario() -> None:
    """``Scenario.run`` on the twin in Case 2 carries the robot's own payload (it took the
    data-sheet payload before)."""
    from mwip.scenario import load_scenario

    ex = Path(__file__).resolve().parents[1] / "examples" / "hodosmc_twin.toml"
    rb = default_robot()
    out = []
    for h in (0.08, 0.10):  # the prior: rods of 0.1 m (book-structures.toml)
        r = rb.with_values({"payload.height": h})
        sc = load_scenario(ex).with_overrides(robot=r, plant=r.body, design=r.design, case=2,
                                               duration=2.0)  # fmt: skip
        out.append(sc.run().series()["y_meas"])
    assert out[0].shape != out[1].shape or not np.allclose(out[0], out[1])


@pytest.mark.parametrize("fact, field", [
    ('scenario = "lqr.toml"\nmetric = "rms_pitch"\nvalue = 0.1\ntolerance = 1.5', "metric"),
    ('scenario = "lqr.toml"\nmetric = "mean_speed"\nvalue = -1.0\ntolerance = 1.5', "value"),
    ('scenario = "lqr.toml"\nmetric = "rms_theta"\nvalue = 0.1\ntolerance = 0.9', "tolerance"),
    ('scenario = "lqr.toml"\nmetric = "rms_theta"\nvalue = 0.1\nwithin = 0.1\n'
     'window = [5.0, 1.0]', "window"),
    ('scenario = "none.toml"\nstands = true', "scenario"),
    ('scenario = "lqr.toml"\nstands = "yes"', "stands"),
    ('scenario = "lqr.toml"\nstands = true\nvalue = 1.0', "value"),
    ('scenario = "lqr.toml"\nstands = true\ncolour = 1', "colour"),
])  # fmt: skip
def test_bad_facts_are_one_line_naming_the_field_and_write_nothing(
        tmp_path: Path, fact: str, field: str) -> None:  # fmt: skip
    facts, robot_file = _setup(tmp_path, rms=0.02, extra="[[fact]]\n" + fact + "\n")
    code, text = _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))
    assert code == 2, text
    assert "fact 3" in text and field in text and "Traceback" not in text
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 3 and lines[-1].startswith("Error: ")  # usage, hint, one message
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, field", [
    (("book", "--robot", "bot.toml"), "--robot"),
    (("facts.toml", "--structures", "S1"), "--structures"),
    (("facts.toml", "--record"), "--record"),
    (("facts.toml", "--robot", "missing.toml"), "--robot"),
])  # fmt: skip
def test_mode_mismatches_are_refused(tmp_path: Path, args: tuple[str, ...], field: str) -> None:
    _setup(tmp_path, rms=0.02)
    full = [str(tmp_path / a) if a.endswith(".toml") else a for a in args]
    code, text = _cli(*full, "--out", str(tmp_path / "o"))
    assert code == 2 and field in text and "Traceback" not in text
    assert not (tmp_path / "o").exists()


def test_a_scenario_off_the_twin_is_refused(tmp_path: Path) -> None:
    facts, robot_file = _setup(tmp_path, rms=0.02)
    (tmp_path / "lqr.toml").write_text(SCENARIO.replace("twin = true\ncase = 1\n", ""))
    code, text = _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))
    assert code == 2 and "twin = true" in text and not (tmp_path / "o").exists()


def test_another_calibrations_folder_is_refused(tmp_path: Path) -> None:
    """A rerun resumes only the same calibration: another facts file into the same folder is
    refused instead of mixing draws."""
    facts, robot_file = _setup(tmp_path, rms=0.02, draws=10, search=0)
    assert _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))[0] == 0
    facts.write_text(facts.read_text().replace("value = 0.02", "value = 0.03"))
    code, text = _cli(str(facts), "--robot", str(robot_file), "--out", str(tmp_path / "o"))
    assert code == 2 and "another calibration" in text
