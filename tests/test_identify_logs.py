"""Bad logs for `mwip twin fit`: exit 2, one line naming the file and the column, nothing
written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main

N = 60


def _cols(**over: object) -> dict[str, np.ndarray]:
    t = np.arange(N) * 0.005
    cols: dict[str, np.ndarray] = {
        "t": t, "theta": 0.01 * np.sin(t), "theta_rate": 0.01 * np.cos(t),
        "enc_r": 0.1 * t, "enc_l": 0.1 * t, "duty_r": 0.2 * np.sin(9 * t),
        "duty_l": 0.2 * np.cos(9 * t),
    }  # fmt: skip
    for k, v in over.items():
        if v is None:
            cols.pop(k)
        else:
            cols[k] = np.asarray(v)
    return cols


def _write(path: Path, cols: dict[str, np.ndarray], rename: dict[str, str] | None = None) -> Path:
    names = list(cols)
    head = [(rename or {}).get(n, n) for n in names]
    rows = [",".join(head)]
    n = len(cols["t"]) if "t" in cols else N
    for i in range(n):
        rows.append(",".join(str(cols[k][i]) for k in names))
    path.write_text("\n".join(rows) + "\n")
    return path


def _cases(tmp: Path) -> list[tuple[str, Path, str]]:
    t = np.arange(N) * 0.005
    bad_t = t.copy()
    bad_t[10] = bad_t[9]
    back = t.copy()
    back[20], back[21] = back[21], back[20]
    nan = 0.01 * np.sin(t)
    nan[5] = np.nan
    out = [
        ("missing", _write(tmp / "a.csv", _cols(theta_rate=None)), "theta_rate"),
        ("misnamed", _write(tmp / "b.csv", _cols(), {"enc_l": "enc_left"}), "enc_l"),
        ("duplicate t", _write(tmp / "c.csv", _cols(t=bad_t)), "t"),
        ("t goes back", _write(tmp / "d.csv", _cols(t=back)), "t"),
        ("nan", _write(tmp / "e.csv", _cols(theta=nan)), "theta"),
        ("degrees", _write(tmp / "f.csv", _cols(theta=np.full(N, 30.0))), "theta"),
        ("duty %", _write(tmp / "g.csv", _cols(duty_r=20 * np.sin(9 * t))), "duty_r"),
        ("mN m", _write(tmp / "h.csv", _cols(duty_r=None, duty_l=None,
                                             u_r=300 * np.sin(t), u_l=300 * np.cos(t))), "u_r"),
        ("constant", _write(tmp / "i.csv", _cols(duty_r=np.zeros(N), duty_l=np.zeros(N))),
         "duty_r"),
        ("one row", _write(tmp / "j.csv", {k: v[:1] for k, v in _cols().items()}), "t"),
        ("bad mode", _write(tmp / "k.csv", _cols(mode=np.array(["flying"] * N))), "mode"),
    ]  # fmt: skip
    d = tmp / "folder.csv"
    d.mkdir()
    out.append(("directory", d, ""))
    b = tmp / "bin.csv"
    b.write_bytes(bytes(range(256)) * 4)
    out.append(("binary", b, ""))
    return out


def test_bad_logs_exit_2_one_line_nothing_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for what, path, column in _cases(tmp_path):
        out = tmp_path / f"out-{what.replace(' ', '_')}"
        rc = main(["twin", "fit", str(path), "--out", str(out)])
        err = capsys.readouterr().err.strip()
        assert rc == 2, (what, err)
        assert len(err.splitlines()) == 1, (what, err)
        assert str(path) in err, (what, err)
        if column:
            assert f"column {column!r}" in err, (what, err)
        assert not out.exists(), what


def test_misnamed_column_suggests_close_name(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    p = _write(tmp_path / "b.csv", _cols(), {"enc_l": "enc_left"})
    assert main(["twin", "fit", str(p), "--out", str(tmp_path / "o")]) == 2
    assert "enc_left" in capsys.readouterr().err


def test_validate_log_is_checked_before_writing(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    good = _write(tmp_path / "good.csv", _cols(mode=np.array(["wheels-off-ground"] * N)))
    bad = _write(tmp_path / "bad.csv", _cols(theta=None))
    out = tmp_path / "o"
    assert main(["twin", "fit", str(good), "--validate", str(bad), "--out", str(out)]) == 2
    assert not out.exists()


def test_excite_writes_schedule(tmp_path: Path) -> None:
    f = tmp_path / "ex.csv"
    assert main(["twin", "excite", "--out", str(f), "--static", "0.5", "--step", "0.05",
                 "--chirp", "0.5"]) == 0  # fmt: skip
    lines = f.read_text().splitlines()
    assert lines[0] == "t,duty_r,duty_l,mode"
    modes = {ln.rsplit(",", 1)[1] for ln in lines[1:]}
    assert modes == {"static", "wheels-off-ground"}


def test_fit_cli_writes_three_files(tmp_path: Path) -> None:
    from mwip.identify import excite, synth

    t, duty, mode = excite.schedule(static=0.3, step=0.06, chirp=0.5)
    truth = synth.draw_truth(7)
    p = synth.write_csv(tmp_path / "log.csv", synth.stand_log(truth, duty, mode, seed=7))
    out = tmp_path / "fit"
    # the fit writes a robot file (robot.toml; it was twin.toml), the delay the firmware's
    fix = "firmware.delay=0.5"
    assert main(["twin", "fit", str(p), "--out", str(out), "--fix", fix]) == 0
    assert {f.name for f in out.iterdir()} >= {"robot.toml", "fit.json", "fit.png"}
    text = (out / "robot.toml").read_text()
    assert "fixed: firmware.delay=0.5" in text and "\ndelay = 0.5 " in text
    from mwip.robot import load_robot

    robot = load_robot(out / "robot.toml")
    assert robot.twin.firmware.delay == 0.5
    assert abs(robot.twin.drive.gear_ratio - truth["drive.gear_ratio"]) < 3
    # deterministic: the same logs give the same robot file
    out2 = tmp_path / "fit2"
    assert main(["twin", "fit", str(p), "--out", str(out2), "--fix", fix]) == 0
    assert (out2 / "robot.toml").read_text() == text


def test_balancing_logs_from_two_controllers_read_and_leave_drive_not_informed(
    tmp_path: Path,
) -> None:
    from mwip.identify import synth
    from mwip.identify.fit import fit
    from mwip.identify.logs import read_log

    truth = synth.draw_truth(3)
    logs = []
    for name in ("lqr", "dlqr"):
        p = synth.write_csv(tmp_path / f"{name}.csv", synth.balancing_log(truth, name, 0.6))
        logs.append(read_log(p))
    res = fit(logs)
    assert res.free == []
    assert res.status["drive.gear_ratio"] == "not informed"
    assert any(f.startswith("drive.gear_ratio") for f in res.flags)


def test_validate_on_a_balancing_log_of_another_controller(tmp_path: Path) -> None:
    """`--validate LOG` with a held-out log of the robot balancing (LQR) while the fit's log is
    the open-loop excitation: fit.json has the balancing prediction errors of the fit and of
    the prior centre, and the fit's are smaller."""
    import json

    from mwip.identify import excite, synth

    t, duty, mode = excite.schedule(static=0.3, step=0.06, chirp=0.5)
    truth = synth.draw_truth(5)
    p = synth.write_csv(tmp_path / "log.csv", synth.stand_log(truth, duty, mode, seed=5))
    v = synth.write_csv(tmp_path / "lqr.csv", synth.balancing_log(truth, "lqr", 0.3, seed=6))
    out = tmp_path / "fit"
    assert main(["twin", "fit", str(p), "--validate", str(v), "--out", str(out)]) == 0
    val = json.loads((out / "fit.json").read_text())["validation"]
    fitted, prior = val["fitted"], val["prior_centre"]
    assert fitted["balance_segments"] >= 5
    assert fitted["balance_enc_rms"] < prior["balance_enc_rms"]
    assert fitted["balance_gyro_rms"] < prior["balance_gyro_rms"]
