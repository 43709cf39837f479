"""The command line: outputs, one-line errors with exit code 2, no partial files."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from mwip.cli import main


def test_simulate_writes_outputs(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(
        [
            "simulate",
            "--controller",
            "lqr",
            "--theta0",
            "0.1745",
            "--duration",
            "3",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "status: ok" in text and "settling time" in text and "max |u|" in text
    assert sorted(p.name for p in out.iterdir()) == [
        ".mwip-output",  # the marker: mwip's own folder (mwip.outdir)
        "plant.toml",  # the simulated robot, for `mwip animate`
        "summary.json",
        "timeseries.csv",
        "timeseries.npz",
    ]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["settling_time"] < 3
    data = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
    assert abs(data["theta"][0] - 0.1745) < 1e-12 and abs(data["theta"][-1]) < 0.01


def test_design_lqr_json(capsys):
    assert main(["design", "lqr", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    K = np.array(doc["K"])
    assert doc["Ts"] is None and K.shape == (2, 5)
    # units damping reading (SPEC section 2); python-control's lqr gives the same
    # (tests/test_pycontrol.py); the literal reading's row is tests/test_lqr.py's
    np.testing.assert_allclose(K[0], [-327.52, 70.71, -74.68, -62.70, 223.60], atol=0.006)
    assert doc["sampled"]["Ts"] == 0.005 and np.array(doc["sampled"]["K"]).shape == (2, 5)
    assert main(["design", "lqr", "--Ts", "0.01", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["Ts"] == 0.01


def test_params_show_and_save(tmp_path, capsys):
    assert main(["params", "show", "nominal", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["params"]["mb"] == 2.5 and doc["derived"]["Gb"] == pytest.approx(2.5 * 9.81 * 0.0582)
    path = tmp_path / "robot.toml"
    assert main(["params", "save", "real", str(path)]) == 0
    # a parameter file loads as a robot file's body (--robot FILE replaces --plant/--params)
    assert main(["simulate", "--robot", str(path), "--duration", "1"]) == 0


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["simulate", "--theta0", "abc"], "--theta0"),
        (["simulate", "--theta0", "2.0"], "--theta0"),
        (["simulate", "--duration", "-1"], "--duration"),
        (["simulate", "--duration", "nan"], "--duration"),
        (["simulate", "--Ts", "0"], "--Ts"),
        (["simulate", "--dt", "0.0003"], "dt"),
        (["simulate", "--robot", "missing.toml"], "--robot"),
        (["simulate", "--controller", "pid"], "--controller"),
        (["design", "lqr", "--Ts", "-0.1"], "--Ts"),
        (["run", "no-such-study"], "STUDY"),
    ],
)
def test_bad_input_one_line_exit_2_no_files(tmp_path, capsys, args, needle):
    out = tmp_path / "o"
    full = args + (["--out", str(out)] if args[0] in ("simulate", "run") else [])
    assert main(full) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mwip: error:") and needle in err
    assert "Traceback" not in err
    assert not out.exists()


def test_bad_params_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[params]\nmb = -2\n")
    assert main(["simulate", "--robot", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    # the robot file's one error format: the file, the field (the body's), its range
    assert err.count("\n") == 1 and "bad.toml" in err and "body.mb = -2 kg" in err
    assert "outside the plausible [0.01, 500] kg" in err
    assert not (tmp_path / "o").exists()


def test_console_script_exit_code_and_no_traceback():
    proc = subprocess.run(
        [sys.executable, "-m", "mwip", "simulate", "--theta0", "9"], capture_output=True, text=True
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "Traceback" not in proc.stderr


def test_existing_output_untouched_on_error(tmp_path):
    out = tmp_path / "o"
    assert main(["simulate", "--duration", "1", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert main(["simulate", "--duration", "-5", "--out", str(out)]) == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_reproduce_list(capsys):
    assert main(["reproduce", "--list"]) == 0
    assert "lqr-gain" in capsys.readouterr().out


def test_design_hodo_prescribed_ie(capsys):
    assert main(["design", "hodo", "--order", "3", "--ie", "0.3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] in ("optimal", "optimal_inaccurate")
    assert doc["ie"] <= 0.3 * 1.01 and len(doc["v"]) == 3 and len(doc["L"]) == 3
    assert all(re < 0 for re, _ in doc["eigenvalues"]) and len(doc["eigenvalues"]) == 9


def test_design_hodo_min_ie_with_radius_text(capsys):
    assert main(["design", "hodo", "-n", "2", "--radius", "30"]) == 0
    out = capsys.readouterr().out
    assert "optimal" in out and "ie = " in out and "eig(D_n)" in out


@pytest.mark.parametrize(
    ("args", "code", "needle"),
    [
        (["-n", "0"], 2, "--order"),
        (["-n", "2", "--ie", "-1"], 2, "--ie"),
        (["-n", "2", "--ie", "0.3", "--radius", "5"], 2, "--radius"),
        (["-n", "2", "--ie", "1e-9"], 1, "observer design failed"),
    ],
)
def test_design_hodo_errors(capsys, args, code, needle):
    assert main(["design", "hodo", *args]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_check_smc(capsys):
    assert main(["check", "smc", "--lambdas", "3,0.2,0.3,3"]) == 0
    out = capsys.readouterr().out
    assert out.count("ok  ") == 9 and "FAIL" not in out
    assert main(["check", "smc", "--lambdas", "3,1.0,0.3", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    failed = [c["name"] for c in doc["conditions"] if not c["holds"]]
    assert "(3.52a)" in failed and doc["ok"] is False
    assert main(["check", "smc", "--lambdas", "3,-1,0.3"]) == 2
    assert "--lambdas" in capsys.readouterr().err


def test_reproduce_reports_a_failing_study_and_runs_the_others(tmp_path, capsys, monkeypatch):
    from mwip.studies import registry
    from mwip.studies.study import Study, save_study

    def good(ctx):
        return save_study(ctx, metrics={"a.x": 1.0},
                          claims=[{"id": "x", "text": "x", "holds": True, "book": False,
                                   "keys": ["a.x"]}],
                          runs={"a": {"status": "ok"}}, settings={})  # fmt: skip

    def bad(ctx):
        raise RuntimeError("boom")

    old = tmp_path / "bad"
    old.mkdir()
    (old / "metrics.json").write_text("{}")  # an earlier result of the failing study is kept
    (tmp_path / ".mwip-output").write_text("")  # ... in an earlier mwip output folder
    declared = {"bad": Study("bad", "x", bad, place=(1,)), "good": Study("good", "test", good,
                                                                      place=(2,))}  # fmt: skip
    monkeypatch.setattr(registry, "_discover", lambda: declared)
    args = ["reproduce", "--out", str(tmp_path), "--quick", "-j", "1", "-v", "--no-compare"]
    assert main(args) == 1
    cap = capsys.readouterr()
    assert "bad: FAILED" in cap.err and "RuntimeError: boom" in cap.err
    assert "[ok] good (test): no book claim, extras 1/1" in cap.out
    assert "1/2 studies done" in cap.out
    assert "     [ok] (ours) x  <a.x=1>" in cap.out
    assert (old / "metrics.json").read_text() == "{}"
    record = json.loads((tmp_path / "run.json").read_text())
    assert record["studies"]["bad"]["error"] == "RuntimeError: boom"
    assert record["studies"]["good"]["error"] is None


def test_design_it2(capsys):
    assert main(["design", "it2", "--epsilon", "0.2", "--rho", "20", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == "optimal" and len(doc["G1"]) == 4 and len(doc["G2"]) == 4
    assert main(["design", "it2", "--epsilon", "0.2", "--rho", "0.1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "infeasible" in err
    # a solver point reported optimal_inaccurate that fails the LMIs: exit 1, one line
    argv = ["design", "it2", "--epsilon", "0.2", "--rho", "0.47097", "--damping", "literal"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fails its check" in err
    assert main(["design", "it2", "--epsilon", "0", "--rho", "3"]) == 2
