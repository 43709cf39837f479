"""Hardening (issue 14): each reproduction of the report is a test here.

Output folders are mwip's own or empty (1), Ctrl-C stops everything at once and loses
nothing (2), work is bounded (3), bad parameter, scenario and study files and study settings
are one-line errors naming the file and the field (4, 5), the API names its arguments (6),
the README's example runs without pandas (7). The generated inputs are in test_fuzz.py.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from mwip.cli import main
from mwip.outdir import MARKER
from mwip.report import render_html
from mwip.studies import registry
from mwip.studies.study import Study, save_study

ROOT = Path(__file__).resolve().parent.parent


def _fake_study(name: str = "good"):
    def run(ctx):
        claim = {"id": "x", "text": "x", "holds": True, "book": False, "keys": ["a.x"]}
        return save_study(ctx, metrics={"a.x": 1.0}, claims=[claim],
                          runs={"a": {"status": "ok"}}, settings={})  # fmt: skip

    return run


@pytest.fixture
def fake_studies(monkeypatch):
    """Two instant studies in place of the book's (for output-folder behaviour)."""
    declared = {"good": Study("good", "x", _fake_study("good"), place=(1,)),
                "other": Study("other", "y", _fake_study("other"), place=(2,))}  # fmt: skip
    monkeypatch.setattr(registry, "_discover", lambda: declared)


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


# ---- 1. output folders ------------------------------------------------------------------------
def test_empty_out_is_refused_and_the_current_folder_untouched(tmp_path, monkeypatch, capsys,
                                                               fake_studies):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    (tmp_path / "index.html").write_text("my page")
    (tmp_path / "good").mkdir()
    (tmp_path / "good" / "notes.txt").write_text("mine")
    for argv in (["reproduce", "--out", "", "-j", "1"], ["run", "good", "--out", ""],
                 ["simulate", "--duration", "0.1", "--out", ""]):  # fmt: skip
        assert main(argv) == 2
        assert "--out" in _err_line(capsys)
    assert (tmp_path / "index.html").read_text() == "my page"
    assert (tmp_path / "good" / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["good", "index.html"]


def test_a_users_folder_is_refused_unless_forced(tmp_path, capsys, fake_studies):
    out = tmp_path / "site"
    (out / "good").mkdir(parents=True)
    (out / "good" / "notes.txt").write_text("mine")  # a folder named like a study
    (out / "index.html").write_text("my page")
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 2
    line = _err_line(capsys)
    assert "--out" in line and "--force" in line and "not empty" in line
    assert (out / "index.html").read_text() == "my page"
    assert (out / "good" / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]  # no staging either
    # --force names it: written, and marked as mwip's from now on
    assert main(["reproduce", "--out", str(out), "-j", "1", "--force"]) == 0
    assert (out / MARKER).is_file() and (out / "good" / "metrics.json").is_file()
    capsys.readouterr()
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 0  # its own folder now
    assert main(["run", "other", "--out", str(out)]) == 2  # reproduce's (issue 25)


def test_new_empty_and_own_folders_are_accepted(tmp_path, fake_studies):
    new = tmp_path / "a" / "b"
    assert main(["run", "good", "--out", str(new)]) == 0
    assert (new / MARKER).is_file()
    assert main(["run", "other", "--out", str(new)]) == 0  # its own folder again
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["run", "good", "--out", str(empty)]) == 0
    sim = tmp_path / "sim"
    assert main(["simulate", "--duration", "0.2", "--out", str(sim)]) == 0
    assert main(["simulate", "--duration", "0.2", "--out", str(sim)]) == 0


def test_simulate_refuses_a_users_folder(tmp_path, capsys):
    (tmp_path / "summary.json").write_text("mine")
    assert main(["simulate", "--duration", "0.2", "--out", str(tmp_path)]) == 2
    assert "--force" in _err_line(capsys)
    assert (tmp_path / "summary.json").read_text() == "mine"


@pytest.mark.parametrize("kind", ["fifo", "folder", "symlink"])
def test_only_regular_files_are_replaced(tmp_path, capsys, kind):
    target = tmp_path / "robot.toml"
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "folder":
        target.mkdir()
    else:
        (tmp_path / "real.toml").write_text("x = 1\n")
        target.symlink_to(tmp_path / "real.toml")
    before = os.lstat(target).st_mode
    for argv in (["params", "save", "real", str(target)], ["scenario", "lqr-gain", "--out",
                                                           str(target)]):  # fmt: skip
        assert main(argv) == 2
        assert "robot.toml" in _err_line(capsys)
    assert os.lstat(target).st_mode == before
    if kind == "symlink":
        assert (tmp_path / "real.toml").read_text() == "x = 1\n"


def test_leftovers_of_a_killed_run_are_removed_by_the_next(tmp_path, fake_studies):
    out = tmp_path / "out"
    assert main(["run", "good", "--out", str(out)]) == 0
    dead = 2**22 + 12345  # above the usual pid_max of 2^22: no such process
    stale = tmp_path / f".out.partial-{dead}-abc"
    stale.mkdir()
    (stale / "half.txt").write_text("x")
    trash = out / f".replaced-{dead}-xyz"
    (trash / "other").mkdir(parents=True)  # an old entry whose replacement never arrived
    (trash / "other" / "metrics.json").write_text("{}")
    live = tmp_path / f".out.partial-{os.getppid()}-live"  # a run still going: kept
    live.mkdir()
    assert main(["run", "good", "--out", str(out)]) == 0
    assert not stale.exists() and not trash.exists() and live.exists()
    assert (out / "other" / "metrics.json").read_text() == "{}"  # put back, not lost


@pytest.mark.parametrize("cut", range(7))
def test_a_commit_cut_short_leaves_index_matching_run_json(tmp_path, monkeypatch, cut,
                                                           fake_studies):  # fmt: skip
    """A kill at any rename of the commit: OUT's index.html is absent or the page of OUT's
    run.json, and no study is lost."""
    import mwip.report.staging as staging

    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 0
    calls = [0]
    real_replace = os.replace

    def replace_then_die(src, dst):
        if calls[0] == cut:
            raise SystemExit(137)  # as if killed here (SystemExit skips the except Exception)
        calls[0] += 1
        real_replace(src, dst)

    monkeypatch.setattr(staging.os, "replace", replace_then_die)
    code = main(["reproduce", "--out", str(out), "-j", "1"])
    monkeypatch.setattr(staging.os, "replace", real_replace)
    assert code in (0, 137)
    record = json.loads((out / "run.json").read_text())
    assert set(record["studies"]) == {"good", "other"}
    if (out / "index.html").exists():
        assert (out / "index.html").read_text() == _page(out)
    assert (out / "good" / "metrics.json").is_file() and (out / "other" / "metrics.json").is_file()


def _page(out: Path) -> str:
    """The report page of OUT as it is now (with its comparison folder, as write_report)."""
    from mwip.report.claims import find_compare

    return render_html(out, None, find_compare(out))


# ---- 2. Ctrl-C ----------------------------------------------------------------------------------
def _reproduce_and_interrupt(tmp_path: Path, twice: bool) -> tuple[int, float, str]:
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "mwip", "reproduce", "--quick", "--out", str(out), "-j", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, start_new_session=True,
    )  # fmt: skip
    _wait_for_staging(proc, tmp_path)
    t0 = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group
    if twice:
        time.sleep(0.2)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:  # pragma: no cover - the failure being tested
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("mwip reproduce did not stop after Ctrl-C")
    return proc.returncode, time.monotonic() - t0, err.decode()


def _wait_for_staging(proc: subprocess.Popen, root: Path) -> None:
    """Until a staging folder exists under ``root`` (studies under way), then 1 s more."""
    deadline = time.monotonic() + 120
    while not _staging(root):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    time.sleep(1.0)


def _staging(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if ".partial-" in p.name or ".replaced-" in p.name]


@pytest.mark.parametrize("twice", [False, True])
def test_ctrl_c_stops_reproduce_at_once(tmp_path, twice):
    code, wall, err = _reproduce_and_interrupt(tmp_path, twice)
    assert code == 130, err
    assert wall < 2.0, f"took {wall:.2f} s to stop"
    assert "Traceback" not in err and "interrupted" in err
    assert not _staging(tmp_path)  # no staging folder left
    out = tmp_path / "out"  # no results: at most the (empty) folder reproduce marked as its own
    assert not out.exists() or sorted(p.name for p in out.iterdir()) == [MARKER]


def test_a_killed_reproduce_leaves_no_workers_and_its_leftovers_go(tmp_path):
    from mwip.report.staging import remove_stale

    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "mwip", "reproduce", "--quick", "--out", str(out), "-j", "2"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True,
    )  # fmt: skip
    _wait_for_staging(proc, tmp_path)
    kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True)
    workers = [int(k) for k in kids.stdout.split()]
    assert workers
    proc.kill()  # SIGKILL: no clean-up at all
    proc.wait()
    deadline = time.monotonic() + 5
    while [w for w in workers if Path(f"/proc/{w}").exists() and not _zombie(w)]:
        assert time.monotonic() < deadline, "worker processes outlived their parent"
        time.sleep(0.1)
    assert _staging(tmp_path)  # left behind by the kill
    for folder in (out, *out.glob("compare-*")):  # what the next run on each does first
        remove_stale(folder)
    remove_stale(out / "compare-literal")
    assert not _staging(tmp_path)


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z"
    except OSError:
        return True


# ---- 3. bounded work ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["--Ts", "1e-9"],
        ["--dt", "1e-12"],
        ["--Ts", "1e-5", "--duration", "3600"],
        ["--mode", "continuous", "--Ts", "1e-6", "--duration", "3600"],
    ],
)
def test_simulate_refuses_runs_above_the_budget_at_once(argv, capsys):
    t0 = time.perf_counter()
    assert main(["simulate", *argv]) == 2
    line = _err_line(capsys)
    assert time.perf_counter() - t0 < 10
    assert "would need" in line and ("GiB" in line or "steps" in line) and "--max-" in line


def test_the_budget_can_be_raised_and_lowered(capsys):
    assert main(["simulate", "--duration", "1", "--max-steps", "100"]) == 2
    assert "budget 100" in _err_line(capsys)
    assert main(["simulate", "--duration", "0.2", "--max-memory", "0.001"]) == 0


def test_long_simulations_show_progress_without_a_terminal(monkeypatch, capsys):
    import mwip.budget as budget

    assert main(["simulate", "--duration", "0.1"]) == 0
    assert capsys.readouterr().err == ""  # short: quiet
    monkeypatch.setattr(budget, "SAMPLE_S", 1.0)  # as if each sample took a second
    # a loop that is not compiled (the law inside the ODE, --mode continuous; the digital
    # twin's sensors and drive now run in the compiled twin loop) reports every tenth
    assert main(["simulate", "--controller", "smc", "--mode", "continuous",
                 "--duration", "0.1"]) == 0  # fmt: skip
    err = capsys.readouterr().err.splitlines()
    assert "about 20 s" in err[0]
    assert err[1:] == [f"simulating: {10 * k}% ({2 * k}/20)" for k in range(1, 11)]
    # the compiled loops (LQR; the twin's) run in one call and report their end
    for twin in ([], ["--twin"]):
        assert main(["simulate", "--duration", "0.1", *twin]) == 0
        err = capsys.readouterr().err.splitlines()
        assert "about 20 s" in err[0] and err[1:] == ["simulating: 100% (20/20)"]


def test_study_step_settings_are_bounded(tmp_path, capsys):
    study = tmp_path / "s.toml"
    text = (ROOT / "src/mwip/studies/scenarios/lqr-gain.toml").read_text()
    study.write_text(text.replace("dt_continuous = 0.001", "dt_continuous = 1e-12"))
    assert main(["run", "--scenario", str(study), "--out", str(tmp_path / "o")]) == 2
    line = _err_line(capsys)
    assert "s.toml" in line and "dt_continuous" in line and "[1e-05, 1]" in line
    assert not (tmp_path / "o").exists()


# ---- 4. parameter and scenario files ------------------------------------------------------------
PARAM_FILES = {  # the text; the field named by a parameter file's reader, by the robot file's
    "nested": ("a = " + "[" * 3000 + "]" * 3000 + "\n", "nested too deeply", "nested too deeply"),
    "array": ("[params]\nmb = [2.0, 3.0]\n", "'mb'", "body.mb"),
    "bool": ("[params]\nmb = true\n", "'mb'", "body.mb"),
    "string": ('[params]\nmb = "2.5"\n', "'mb'", "body.mb"),
    "table": ("[params.mb]\nx = 1\n", "'mb'", "body.mb"),
    "tiny_radius": ("[params]\nr = 1e-300\n", "'r'", "body.r"),
    "huge_radius": ("[params]\nr = 1e300\n", "'r'", "body.r"),
    "base_list": ('base = ["real"]\n', "'base'", "base must be one of real, nominal"),
}


@pytest.mark.parametrize("case", list(PARAM_FILES))
def test_bad_parameter_files_are_one_line_naming_file_and_field(case, tmp_path, capsys):
    text, field, robot_field = PARAM_FILES[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(text)
    # `mwip simulate` takes the robot file (--robot; a parameter file loads as one): its
    # errors name the robot file's field
    for argv, name in ((["params", "show", str(path)], field),
                       (["design", "lqr", "--params", str(path)], field),
                       (["simulate", "--robot", str(path), "--duration", "0.1"], robot_field)):
        assert main(argv) == 2
        line = _err_line(capsys)
        assert f"{case}.toml" in line and name in line


@pytest.mark.parametrize("value", ["", ".", "/"])
def test_a_folder_or_empty_name_as_a_file(value, capsys):
    for argv in (["params", "show", value], ["simulate", "--scenario", value],
                 ["run", "--scenario", value]):  # fmt: skip
        assert main(argv) == 2
        _err_line(capsys)


SCENARIOS = {
    "duration_string": ('[scenario]\nduration = "10"\n', "duration"),
    "duration_bool": ("[scenario]\nduration = true\n", "duration"),
    "duration_table": ("[scenario.duration]\nx = 1\n", "duration"),
    "scenario_value": ("scenario = 3\n", "[scenario]"),
    "initial_string": ('[initial]\ntheta = "0.1"\n', "theta"),
    "initial_list": ("[initial]\ntheta = [0.1]\n", "theta"),
    "plant_bool": ("[plant]\nmb = true\n", "mb"),
    "plant_array": ("[plant]\nmb = [1.0, 2.0]\n", "mb"),
    "plant_radius": ("[plant]\nr = 1e-300\n", "'r'"),
    "base_number": ("[plant]\nbase = 3\n", "base"),
    "disturbance_kind": ("[disturbance]\nkind = 3\n", "kind"),
    "disturbance_amp": ('[disturbance]\nkind = "sinusoid"\namplitude = "x"\n', "amplitude"),
    "pulse_start": (
        '[disturbance]\nkind = "pulse"\nvalue = 1.0\nstart = "1"\nwidth = 1.0\n',
        "start",
    ),
    "mode_list": ('[scenario]\nmode = ["sampled"]\n', "mode"),
}


@pytest.mark.parametrize("case", list(SCENARIOS))
def test_bad_scenario_files_are_one_line_naming_file_and_field(case, tmp_path, capsys):
    text, field = SCENARIOS[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(text)
    assert main(["simulate", "--scenario", str(path)]) == 2
    line = _err_line(capsys)
    assert f"{case}.toml" in line and field in line


# ---- 5. study settings --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "study, setting, field, allowed",
    [
        ("lqr-gain", "theta0 = 2.0", "theta0", "(-1.5708, 1.5708)"),
        ("lqr-gain", "duration = -1.0", "duration", "(0, 3600]"),
        ("asta-balance", "lam = [10.0, -0.3, 0.3]", "lam[1]", "(0, 1e+06]"),
        ("asta-balance", "dt = 0.0003", "dt", "divide"),
        ("tsmc-circle", "D = 1.0", "D", "[0, 1)"),
        ("exp-asta", "seed = -1", "seed", "[0, 4294967295]"),
        ("exp-it2", "uncertainty = 1.5", "uncertainty", "[0, 1)"),
        ("asta-velocity", "rms_window = [10.0, 5.0]", "rms_window", "start < end"),
    ],
)
def test_study_settings_are_range_checked_before_anything_runs(
    study, setting, field, allowed, tmp_path, capsys
):
    from mwip.studies.settings import packaged_text

    key = setting.split(" =")[0]
    text = re.sub(rf"(?m)^{re.escape(key)} = .*$", setting, packaged_text(study), count=1)
    path = tmp_path / "mine.toml"
    path.write_text(text)
    assert main(["run", "--scenario", str(path), "--out", str(tmp_path / "o")]) == 2
    line = _err_line(capsys)
    assert "mine.toml" in line and f"[settings] {field}" in line and allowed in line
    assert not (tmp_path / "o").exists()


def test_a_packaged_study_file_with_its_ranges_loads_and_edited_ranges_do_not(tmp_path):
    from mwip.studies.settings import packaged_text
    from mwip.studies.study_file import load_study_file

    path = tmp_path / "t.toml"
    text = packaged_text("tsmc-circle")
    path.write_text(text)
    assert load_study_file(path).name == "tsmc-circle"
    path.write_text(text.replace('D = "[0, 1)"', 'D = "[0, 5)"'))
    with pytest.raises(ValueError, match=r"t\.toml.*\[ranges\]"):
        load_study_file(path)


@pytest.mark.parametrize("lambdas", ["3,,0.2,0.3", "3,0.2,0.3,", ",3,0.2,0.3", "3, ,0.2"])
def test_check_smc_refuses_empty_lambdas(lambdas, capsys):
    assert main(["check", "smc", "--lambdas", lambdas]) == 2
    assert "--lambdas" in _err_line(capsys)


# ---- 6. the API ---------------------------------------------------------------------------------
def _api_cases():
    from mwip import NOMINAL, REAL
    from mwip.laws import LQR, design_lqr
    from mwip.laws.smc.design import check_smc_design
    from mwip.models.linear import linearize
    from mwip.params import Params
    from mwip.sim import simulate

    ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
    return {
        "duration": lambda: simulate(ctrl, REAL, duration="10"),
        "Ts": lambda: design_lqr(NOMINAL, Ts="0.005"),
        "reference": lambda: LQR(design_lqr(NOMINAL), reference=math.nan),
        "'mb'": lambda: Params(**{**REAL.to_dict(), "mb": True}),
        "q0": lambda: simulate(ctrl, REAL, q0=(0, "0.1", 0)),
        "record_every": lambda: simulate(ctrl, REAL, duration=0.1, record_every=1.5),
        "seed": lambda: simulate(ctrl, REAL, duration=0.1, seed="x"),
        "plant": lambda: simulate(ctrl, "real", duration=0.1),
        "params": lambda: design_lqr("nominal"),
        "Q": lambda: design_lqr(NOMINAL, Q="diag"),
        "'r'": lambda: replace(REAL, r=1e-300),
        "dt": lambda: simulate(ctrl, REAL, duration=1.0, dt=math.inf),
        "lambdas": lambda: check_smc_design("3,0.2,0.3", NOMINAL, 0.3),
        "mwip.params.Params": lambda: linearize("real"),
    }


@pytest.mark.parametrize("name", list(_api_cases()))
def test_api_errors_name_the_argument(name):
    with pytest.raises((TypeError, ValueError)) as info:
        _api_cases()[name]()
    assert name in str(info.value)
    assert info.type.__module__ in ("builtins", "mwip.budget")


def test_simulate_budget_error_names_the_cost():
    from mwip import NOMINAL, REAL
    from mwip.budget import Budget, BudgetError
    from mwip.laws import LQR, design_lqr
    from mwip.sim import simulate

    ctrl = LQR(design_lqr(NOMINAL, Ts=1e-5))
    with pytest.raises(BudgetError, match="GiB"):
        simulate(ctrl, REAL, duration=3600, Ts=1e-5)
    res = simulate(ctrl, REAL, duration=0.01, Ts=1e-5, budget=Budget(max_steps=1e4))
    assert res.t.size == 1001
    with pytest.raises(BudgetError, match="budget 10"):
        simulate(ctrl, REAL, duration=0.01, Ts=1e-5, budget=Budget(max_steps=10))


@pytest.mark.parametrize(
    "content", ["{not json", "[1, 2]", "", '"text"', '{"claims": 3}', '{"metrics": [1]}']
)
def test_report_names_a_corrupt_metrics_file(content, tmp_path, capsys, fake_studies):
    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 0
    capsys.readouterr()
    (out / "good" / "metrics.json").write_text(content)
    assert main(["report", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert str(out / "good" / "metrics.json") in err and "Traceback" not in err


# ---- 7. the README's example --------------------------------------------------------------------
def test_readme_example_runs_without_pandas(monkeypatch, capsys):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.setitem(sys.modules, "pandas", None)  # `pip install -e .` brings no pandas
    block = block.replace("1000", "40")  # the same code on a smaller batch (test time)
    exec(compile(block, "README.md", "exec"), {})
    assert "status" in capsys.readouterr().out
    from mwip import NOMINAL, REAL
    from mwip.laws import LQR, design_lqr
    from mwip.sim import simulate

    res = simulate(LQR(design_lqr(NOMINAL)), REAL, duration=0.05, mode="continuous")
    with pytest.raises(ImportError, match=r"mwip\[pandas\]"):
        res.to_dataframe()


def test_no_traceback_from_the_console_script(tmp_path):
    """The subprocess path: exit code 2 and one line for a few bad inputs."""
    bad = tmp_path / "deep.toml"
    bad.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    for argv in (
        ["params", "show", str(bad)],
        ["simulate", "--Ts", "1e-9"],
        ["params", "save", "real", str(tmp_path)],
        ["check", "smc", "--lambdas", "3,,1"],
    ):
        proc = subprocess.run([sys.executable, "-m", "mwip", *argv], capture_output=True,
                              text=True, env=env, timeout=120)  # fmt: skip
        assert proc.returncode == 2, (argv, proc.stderr)
        assert "Traceback" not in proc.stderr and proc.stderr.strip().count("\n") == 0, argv


def test_arrays_from_params_files_are_not_batches(tmp_path):
    from mwip.params import load_params

    path = tmp_path / "p.toml"
    path.write_text("[params]\nmb = [2.0, 3.0]\n")
    with pytest.raises(ValueError, match=r"p\.toml.*'mb'.*one robot"):
        load_params(path, base=None)
    from mwip.params import REAL, stack_params

    assert stack_params([REAL, REAL]).batch_shape == (2,)  # batches stay an API feature


def test_concurrent_runs_into_one_folder_leave_it_consistent(tmp_path, fake_studies):
    import threading

    from mwip.studies.runner import run_studies

    out = tmp_path / "out"
    errors: list[BaseException] = []

    def one(name: str) -> None:
        try:
            for _ in range(3):
                run_studies([name], out, jobs=1)
        except BaseException as exc:  # pragma: no cover - the failure being tested
            errors.append(exc)

    threads = [threading.Thread(target=one, args=(n,)) for n in ("good", "other")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert (out / "index.html").read_text() == _page(out)
    assert sorted(p.name for p in out.iterdir()) == [".mwip-output", "good", "index.html",
                                                     "other", "run.json"]  # fmt: skip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
