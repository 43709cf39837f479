"""`mwip twin log` (issue 37, item 6): the log a robot would write, simulated on its twin from
its robot file, so the chain (log -> `mwip twin fit` -> ...) can be tried without hardware.

Synthetic truth through the command line: a robot of gear ratio 12 (the default's 5.3) and
heavier wheels writes a stand log for `mwip twin excite`'s schedule; `mwip twin fit` on that
robot's file gives the gear ratio back within three of its standard errors. A balancing log
passes the fit's log checks and depends on the robot. Bad input: one line, exit 2, no file."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.identify.logs import read_log
from mwip.robot import default_robot, save_robot


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("twin_log")
    r = default_robot()
    g12 = r.with_values({"drive.gear_ratio": 12.0})
    g12 = replace(g12, body=replace(g12.body, Iwa=2.0 * g12.body.Iwa))
    sched = d / "sched.csv"
    assert main(["twin", "excite", "--out", str(sched), "--static", "0.3", "--step", "0.06",
                 "--chirp", "0.5"]) == 0  # fmt: skip
    return {"dir": d, "sched": sched, "g12": save_robot(g12, d / "g12.toml")}


def _log(files: dict[str, Path], name: str, *args: str) -> Path:
    out = files["dir"] / name
    assert main(["twin", "log", *args, "--out", str(out)]) == 0
    return out


def test_a_stand_log_gives_its_robot_back(files: dict[str, Path]) -> None:
    log = _log(files, "stand.csv", "--robot", str(files["g12"]), "--excite", str(files["sched"]))
    lg = read_log(str(log))
    assert set(np.unique(lg.mode)) == {"static", "wheels-off-ground"} and lg.inputs == "duty"
    fit = files["dir"] / "fit"
    assert main(["twin", "fit", str(log), "--robot", str(files["g12"]), "--out", str(fit)]) == 0
    doc = json.loads((fit / "fit.json").read_text())
    n, se = doc["estimates"]["drive.gear_ratio"], doc["stderr"]["drive.gear_ratio"]
    assert abs(n - 12.0) <= 3.0 * se and se < 1.0, (n, se)  # the default's 5.3 is far outside


def test_a_balancing_log_passes_the_checks_and_follows_the_robot(files: dict[str, Path]) -> None:
    robots = {"default": [], "g12": ["--robot", str(files["g12"])]}
    logs = {name: read_log(str(_log(files, f"bal-{name}.csv", *extra, "--controller", "lqr",
                                    "--duration", "1")))
            for name, extra in robots.items()}  # fmt: skip
    for lg in logs.values():
        assert lg.n == 201 and lg.inputs == "torque" and np.all(lg.mode == "balancing")
    # the same law and lean on another drive and wheels: another trajectory
    assert not np.allclose(logs["default"].enc, logs["g12"].enc, atol=1e-4)


def test_the_seed_decides_the_noise(files: dict[str, Path]) -> None:
    a = _log(files, "s0a.csv", "--excite", str(files["sched"]))
    b = _log(files, "s0b.csv", "--excite", str(files["sched"]))
    c = _log(files, "s1.csv", "--excite", str(files["sched"]), "--seed", "1")
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()


@pytest.mark.parametrize(("case", "needle"), [
    ("neither", "give one of --excite"),
    ("both", "give one of --excite"),
    ("bad-inputs", "--inputs"),
    ("unknown-controller", "--controller: unknown controller 'nope'"),
    ("no-mode", "no column 'mode'"),
    ("other-ts", "steps of 0.01 s, the robot samples every 0.005 s"),
    ("duty-over-1", "column 'duty_r': duties are within -1..1"),
    ("bad-mode", "column 'mode': row 3 is 'balancing'"),
    ("not-a-number", "column 'duty_l': row 2 is not a number"),
    ("foreign-file", "--force"),
    ("dither-on-a-stand", "--dither adds to a controller's command: give --controller"),
    ("dither-too-big", "--dither"),
])  # fmt: skip
def test_bad_input_is_one_line(files: dict[str, Path], tmp_path: Path, capsys, case: str,
                               needle: str) -> None:  # fmt: skip
    sched = tmp_path / "s.csv"
    rows = {"no-mode": "t,duty_r,duty_l\n0,0,0\n0.005,0,0\n",
            "other-ts": "t,duty_r,duty_l,mode\n0,0,0,static\n0.01,0,0,static\n",
            "duty-over-1": "t,duty_r,duty_l,mode\n0,0,0,static\n0.005,1.5,0,static\n",
            "bad-mode": "t,duty_r,duty_l,mode\n0,0,0,static\n0.005,0,0,balancing\n",
            "not-a-number": "t,duty_r,duty_l,mode\n0,0,x,static\n"}  # fmt: skip
    sched.write_text(rows.get(case, "t,duty_r,duty_l,mode\n0,0,0,static\n"))
    out = tmp_path / "log.csv"
    args = {"neither": [],
            "both": ["--excite", str(sched), "--controller", "lqr"],
            "bad-inputs": ["--controller", "lqr", "--inputs", "volts"],
            "unknown-controller": ["--controller", "nope"],
            "dither-on-a-stand": ["--excite", str(sched), "--dither", "0.05"],
            "dither-too-big": ["--controller", "lqr", "--dither", "5"],
            }.get(case, ["--excite", str(sched)])  # fmt: skip
    if case == "foreign-file":
        out.write_text("mine\n")
    code = main(["twin", "log", *args, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and err.startswith("mwip: error:"), err
    assert needle in err, err
    assert (out.read_text() == "mine\n") if case == "foreign-file" else not out.exists()


def test_the_fit_prints_its_estimates_and_validation(files: dict[str, Path], capsys) -> None:
    """Issue 37, item 5: the terminal shows every estimate with its standard error, status and
    prior range, and the validation log's prediction errors beside the prior centre's."""
    stand = _log(files, "p-stand.csv", "--excite", str(files["sched"]))
    bal = _log(files, "p-bal.csv", "--controller", "lqr", "--duration", "1")
    capsys.readouterr()
    out = files["dir"] / "p-fit"
    assert main(["twin", "fit", str(stand), "--validate", str(bal), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    doc = json.loads((out / "fit.json").read_text())
    lines = {ln.split()[0]: ln for ln in text.splitlines() if ln.split()}
    for name, value in doc["estimates"].items():
        assert f"{value:.5g}" in lines[name] and doc["status"][name] in lines[name], name
    (val,) = [ln for ln in text.splitlines() if ln.startswith("validation on ")]
    v = doc["validation"]
    assert f"{v['fitted']['balance_enc_rms']:.3g} rad (prior centre " \
           f"{v['prior_centre']['balance_enc_rms']:.3g})" in val  # fmt: skip
    # the page: the same estimates beside the prior, the validation, correlations, diagnostics
    page = (out / "index.html").read_text()
    for name, value in doc["estimates"].items():
        assert f"<td>{name}</td><td>{value:.5g}</td>" in page, name
    for head in ("Validation on", "Correlation of the fitted parameters", "Residual diagnostics",
                 "<img src='fit.png'"):  # fmt: skip
        assert head in page, head
    assert f"<td>balance_enc_rms</td><td>{v['fitted']['balance_enc_rms']:.4g}</td>" in page


def test_an_estimate_at_a_bound_says_so() -> None:
    from mwip.identify.bounds import BOUNDS
    from mwip.identify.fit import FitResult, at_bound, summary_lines

    lo, hi = BOUNDS["gearbox.coulomb"]
    assert at_bound("gearbox.coulomb", lo) == "lower" and at_bound("gearbox.coulomb", hi) == "upper"
    assert at_bound("gearbox.coulomb", 0.5 * (lo + hi)) is None
    res = FitResult(estimates={"gearbox.coulomb": lo, "drive.gear_ratio": 12.0},
                    stderr={"gearbox.coulomb": 1e-4, "drive.gear_ratio": 0.4},
                    status={"gearbox.coulomb": "fitted", "drive.gear_ratio": "fitted"},
                    free=[], fixed={}, correlation={}, flags=[], condition=None, residuals={},
                    Ts=0.005, segment=40, experiments={})  # fmt: skip
    text = "\n".join(summary_lines(res))
    assert "fitted (at its lower bound)" in text and text.count("at its") == 1


@pytest.mark.parametrize(("log", "name", "needs"), [
    ("stand", "imu.height", "measure it"),
    ("balancing", "drive.gear_ratio", "wheels-off-ground rows"),
])  # fmt: skip
def test_a_parameter_nothing_informs_is_not_fitted(files: dict[str, Path], tmp_path: Path,
                                                   capsys, log: str, name: str,
                                                   needs: str) -> None:  # fmt: skip
    """Issue 37, item 4: `--free NAME` where no log informs NAME is refused with what would
    inform it, and the way to hold it instead."""
    path = (_log(files, "r-stand.csv", "--excite", str(files["sched"])) if log == "stand"
            else _log(files, "r-bal.csv", "--controller", "lqr", "--duration", "1"))  # fmt: skip
    capsys.readouterr()
    out = tmp_path / "fit"
    assert main(["twin", "fit", str(path), "--free", name, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--free {name}: no log informs it" in err, err
    assert needs in err and f"--fix {name}=VALUE" in err and not out.exists()
