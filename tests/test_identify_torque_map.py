"""Logs as boards write them (issue 37, item 1): the commanded torques and the duties together.

- `read_log` takes both pairs (the duty drives the motor model) and reads a column with no
  value in any row as absent; the mode error lists the modes.
- Synthetic truth through the command line: a robot whose firmware's torque gain is 2 (it
  delivers twice the commanded torque) writes a stand log with both pairs (`mwip twin log
  --inputs both`); `mwip twin fit` gives the gain back within three standard errors and
  writes it into the fitted robot file. The same robot's duties alone give no gain.
- A torque-only log is mapped to duties with the robot file's torque gain: fitted on that
  robot's file, the gear ratio comes back; on a file that believes the gain is 1, it cannot.
- Duties that follow no map of the torques (a duty logged after the back-EMF compensation):
  one line, exit 2, nothing written.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.identify import synth
from mwip.identify.logs import LogError, read_log
from mwip.identify.torque_map import MISFIT_MAX, torque_to_duty
from mwip.robot import default_robot, load_robot, save_robot

GAIN = 2.0


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("torque_map")
    r = default_robot()
    sched = d / "sched.csv"
    assert main(["twin", "excite", "--out", str(sched), "--static", "0.3", "--step", "0.06",
                 "--chirp", "0.5"]) == 0  # fmt: skip
    k2 = save_robot(r.with_values({"firmware.torque_gain": GAIN}), d / "k2.toml")
    out = {"dir": d, "sched": sched, "k2": k2}
    for inputs in ("both", "duty", "torque"):
        out[inputs] = d / f"stand-{inputs}.csv"
        assert main(["twin", "log", "--robot", str(k2), "--excite", str(sched), "--inputs",
                     inputs, "--out", str(out[inputs])]) == 0  # fmt: skip
    return out


def _fit(files: dict[str, Path], log: str, robot: str | None, name: str) -> dict:
    out = files["dir"] / name
    args = ["twin", "fit", str(files[log]), "--out", str(out)]
    assert main([*args, *(["--robot", str(files[robot])] if robot else [])]) == 0
    return json.loads((out / "fit.json").read_text())


def test_both_pairs_are_read_and_the_duty_drives(files: dict[str, Path]) -> None:
    lg = read_log(str(files["both"]))
    assert lg.inputs == "duty" and lg.both_inputs and "u_r" in lg.columns
    duty_only = read_log(str(files["duty"]))
    assert np.array_equal(lg.command, duty_only.command) and not duty_only.both_inputs
    tm = torque_to_duty([lg])
    assert tm is not None and tm.misfit < 1e-9  # the firmware's map, exactly
    assert torque_to_duty([duty_only]) is None


def test_the_torque_gain_comes_back(files: dict[str, Path]) -> None:
    doc = _fit(files, "both", "k2", "fit-both")
    tm = doc["torque_to_duty"]
    assert abs(tm["torque_gain"] - GAIN) <= 3.0 * tm["stderr"] and tm["stderr"] < 0.2, tm
    fitted = load_robot(files["dir"] / "fit-both" / "robot.toml")
    assert fitted.twin.firmware.torque_gain == pytest.approx(tm["torque_gain"], rel=1e-12)
    assert "torque-to-duty map" in (files["dir"] / "fit-both" / "robot.toml").read_text()
    assert _fit(files, "duty", "k2", "fit-duty")["torque_to_duty"] is None


def test_a_torque_log_is_read_with_the_robots_torque_gain(files: dict[str, Path]) -> None:
    """On the robot's own file the gear ratio comes back; on a file whose firmware believes
    its drive (gain 1), every duty is half the board's and no drive explains the wheels: the
    encoder residual is over ten times larger (35 times when this test was written)."""
    true_n = default_robot().twin.drive.gear_ratio
    docs = {name: _fit(files, "torque", robot, f"fit-torque-{name}")
            for name, robot in (("k2", "k2"), ("k1", None))}  # fmt: skip
    n, se = docs["k2"]["estimates"]["drive.gear_ratio"], docs["k2"]["stderr"]["drive.gear_ratio"]
    assert abs(n - true_n) <= 3.0 * se and se < 0.5, (n, se)
    rms = {k: d["residuals"]["enc"]["rms"] for k, d in docs.items()}
    assert rms["k1"] > 10.0 * rms["k2"], rms


def _board_log(tmp: Path, name: str, cols: dict, mutate) -> Path:  # noqa: ANN001
    cols = {k: np.array(v, copy=True) for k, v in cols.items()}
    mutate(cols)
    path = tmp / name
    path.write_text(synth.csv_text(cols))
    return path


def test_duties_that_follow_no_map_are_refused(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = {k: np.asarray(v) for k, v in synth.stand_log_on(
        default_robot().twin, default_robot().body, *_schedule(files), inputs="both").items()}
    w = np.gradient(base["enc_r"], 0.005)

    def compensated(c: dict) -> None:  # the duty after a full back-EMF compensation
        emf = default_robot().twin.motor.k_e * default_robot().twin.drive.gear_ratio / 24.0
        c["duty_r"] = np.clip(c["duty_r"] + emf * w, -1.0, 1.0)
        c["duty_l"] = np.clip(c["duty_l"] + emf * np.gradient(c["enc_l"], 0.005), -1.0, 1.0)

    def shifted(c: dict) -> None:  # the duty of the next sample
        c["duty_r"] = np.roll(c["duty_r"], 1)
        c["duty_l"] = np.roll(c["duty_l"], 1)

    for name, mutate in (("compensated", compensated), ("shifted", shifted)):
        log = _board_log(tmp_path, f"{name}.csv", base, mutate)
        with pytest.raises(LogError, match="follow no torque-to-duty map"):
            torque_to_duty([read_log(str(log))])
        out = tmp_path / f"out-{name}"
        assert main(["twin", "fit", str(log), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "column 'duty_r'" in err and str(log) in err
        assert f"above {100 * MISFIT_MAX:g} %" in err and not out.exists()


def _schedule(files: dict[str, Path]) -> tuple[np.ndarray, np.ndarray]:
    from mwip.identify.excite import read_schedule

    return read_schedule(files["sched"], default_robot().Ts)


def test_an_empty_column_is_an_absent_column(files: dict[str, Path], tmp_path: Path) -> None:
    text = files["duty"].read_text().splitlines()
    head = text[0] + ",u_r,u_l,accel_z"
    rows = [head] + [line + ",,," for line in text[1:]]
    path = tmp_path / "empty.csv"
    path.write_text("\n".join(rows) + "\n")
    lg = read_log(str(path))
    assert lg.inputs == "duty" and not lg.both_inputs and "u_r" not in lg.columns


def test_a_bad_mode_lists_the_modes(tmp_path: Path) -> None:
    t = np.arange(60) * 0.005
    cols = {"t": t, "theta": 0.01 * np.sin(t), "theta_rate": 0.01 * np.cos(t),
            "enc_r": 0.1 * t, "enc_l": 0.1 * t, "duty_r": 0.2 * np.sin(9 * t),
            "duty_l": 0.2 * np.cos(9 * t), "mode": np.array(["flying"] * 60)}  # fmt: skip
    path = tmp_path / "mode.csv"
    path.write_text(synth.csv_text(cols))
    with pytest.raises(LogError, match="balancing, wheels-off-ground, static"):
        read_log(str(path))
