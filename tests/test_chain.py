"""The chain as a tutorial (issue 37, item 7; docs/twin_fit.md, "From the logs to the board"):
a robot's logs -> `mwip twin fit` -> `mwip tune` -> `mwip bench` -> `mwip export c --verify`,
at small sizes, on a robot that is not the book's (gear ratio 12, wheels twice as heavy). Each
step must have used the fitted robot: the fit gives the robot's gear ratio back, and tuning,
the benchmark and the verified export on the fitted robot each differ from the same command
on the default robot (the same seeds and settings)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

from mwip.cli import main
from mwip.robot import default_robot, load_robot, save_robot

pytestmark = pytest.mark.slow


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(args) == 0, capsys.readouterr().err
    return capsys.readouterr().out


def test_logs_to_board_on_the_fitted_robot(tmp_path: Path, capsys) -> None:
    r = default_robot()
    mine = r.with_values({"drive.gear_ratio": 12.0})
    mine = replace(mine, body=replace(mine.body, Iwa=2.0 * mine.body.Iwa))
    robot = save_robot(mine, tmp_path / "mine.toml")
    sched, log, fitted = tmp_path / "ex.csv", tmp_path / "log.csv", tmp_path / "fitted"
    _run(["twin", "excite", "--out", str(sched), "--static", "0.3", "--step", "0.06",
          "--chirp", "0.5"], capsys)  # fmt: skip
    _run(["twin", "log", "--robot", str(robot), "--excite", str(sched), "--out", str(log)],
         capsys)  # fmt: skip
    _run(["twin", "fit", str(log), "--robot", str(robot), "--out", str(fitted)], capsys)
    doc = json.loads((fitted / "fit.json").read_text())
    n, se = doc["estimates"]["drive.gear_ratio"], doc["stderr"]["drive.gear_ratio"]
    assert abs(n - 12.0) <= 3.0 * se
    fitted_robot = fitted / "robot.toml"
    assert load_robot(fitted_robot).body == mine.body

    results = {}
    for name, extra in (("fitted", ["--robot", str(fitted_robot)]), ("book", [])):
        d = tmp_path / name
        _run(["tune", "hodosmc", *extra, "--out", str(d / "tuned"), "--trials", "2"], capsys)
        trials = pd.read_csv(d / "tuned" / "trials.csv")
        best = d / "tuned" / "best.toml"
        _run(["bench", "hodosmc", *extra, "--settings", str(best), "--out", str(d / "bench"),
              "--quick", "--jobs", "1"], capsys)  # fmt: skip
        scores = pd.read_parquet(d / "bench" / "scores.parquet")
        out = _run(["export", "c", "--controller", "hodosmc", "--settings", str(best), *extra,
                    "--out", str(d / "board"), "--verify", "--twin", "--duration", "1"],
                   capsys)  # fmt: skip
        peak = float(out.rsplit("peak delivered torque ", 1)[1].split()[0])
        results[name] = (trials, scores, peak, best.read_text())
    (t_fit, s_fit, p_fit, b_fit), (t_book, s_book, p_book, _) = results["fitted"], results["book"]
    assert "--robot (" in b_fit.splitlines()[0]  # the tuned settings say which robot
    assert not t_fit["value0"].equals(t_book["value0"])  # tuning ran on the fitted robot
    num = s_fit.select_dtypes("number").columns
    assert not s_fit[num].equals(s_book[num])  # so did the benchmark
    assert p_fit != p_book  # and the verified export
