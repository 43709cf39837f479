"""`mwip bench`: the definition, deterministic scores independent of --jobs, resuming after an
interruption, bad input, and sanity invariants (a level without effects repeats the nominal
runs; a controller that cannot balance scores 0; the intervals are Wilson's)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mwip.bench.entrants import resolve_entrants
from mwip.bench.finish import run_bench
from mwip.bench.run import BenchRun, Entrant
from mwip.bench.scores import POOLED
from mwip.bench.spec import builtin_text, load_bench, parse_bench
from mwip.campaign.stats import wilson
from mwip.cli import main
from mwip.core import Measurement
from mwip.schema.settings import read_settings_file, settings_text, write_settings_file

#: A small definition: three axes, levels with and without effects, short runs, small blocks.
SMALL = """
[bench]
seed = 5
samples = 3
duration = 0.6
block = 4
push_at = 0.1
push_width = 0.1
[[axis]]
name = "nominal"
[[axis.level]]
label = "twin"
[[axis]]
name = "none"
source = "levels that change nothing"
[[axis.level]]
label = "posterior"
twin = "posterior"
[[axis.level]]
label = "push 0"
push = 0.0
[[axis.level]]
label = "noise x1"
noise = 1.0
[[axis]]
name = "hard"
[[axis.level]]
label = "delay 2"
delay = 2.0
[[axis.level]]
label = "push"
push = 2.0
[[axis.level]]
label = "model"
params = { mb = 0.2, l = 0.2 }
[[axis.level]]
label = "all"
noise = 4.0
torque_noise = 0.05
responsiveness = 0.5
deadband = 0.02
payload = 0.5
twin = "prior"
"""


def quiet(*_a: object) -> None:
    return None


def small(tmp_path: Path) -> Path:
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    return path


def work(entrants: tuple[Entrant, ...] = (Entrant("dlqr", "dlqr"),)) -> BenchRun:
    return BenchRun(parse_bench(tomllib.loads(SMALL)), entrants)


# ---- the definition ---------------------------------------------------------------------------
def test_builtin_definition_declares_every_axis_with_its_source() -> None:
    b = load_bench()
    names = [a.name for a in b.axes]
    for axis in ("nominal", "model", "twin", "measurement_noise", "actuator_noise", "deadband",
                 "responsiveness", "delay", "payload", "push"):  # fmt: skip
        assert axis in names
    assert all(a.source for a in b.axes)
    delays = [float(lv.delay or 0.0) for lv in next(a for a in b.axes if a.name == "delay").levels]
    assert min(delays) == 0.0 and max(delays) == 2.0  # 0 to 2 samples
    model = next(a for a in b.axes if a.name == "model")
    assert {k for lv in model.levels for k, _ in lv.params} == {
        "mb", "mw", "Iby", "Ibz", "Iwa", "Iwd", "l", "b", "r", "Db", "Dw"}
    q = load_bench(quick=True)
    assert q.samples < b.samples and q.duration < b.duration and q.levels == b.levels
    assert tomllib.loads(builtin_text())["bench"]["samples"] == b.samples


@pytest.mark.parametrize(("edit", "field"), [
    ("samples = 3", "bench.samples"),
    ("delay = 2.0", "delay"),
    ("twin = \"posterior\"", "twin"),
    ("params = { mb = 0.2, l = 0.2 }", "params"),
])  # fmt: skip
def test_bad_definition_names_the_field(edit: str, field: str) -> None:
    bad = {"samples = 3": "samples = 0", "delay = 2.0": "delay = 11.0",
           "twin = \"posterior\"": "twin = [\"stick.height\"]",
           "params = { mb = 0.2, l = 0.2 }": "params = { mass = 0.2 }"}[edit]  # fmt: skip
    with pytest.raises(ValueError, match=field.replace(".", r"\.")) as exc:
        parse_bench(tomllib.loads(SMALL.replace(edit, bad, 1)))
    assert "\n" not in str(exc.value)


# ---- determinism, --jobs, resuming ------------------------------------------------------------
@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """One uninterrupted run of the small definition, in this process (--jobs 1)."""
    root = tmp_path_factory.mktemp("bench")
    out = root / "ref"
    assert main(["bench", "dlqr", "hodosmc", "--definition", str(small(root)), "--jobs", "1",
                 "--out", str(out)]) == 0  # fmt: skip
    return out, root


@pytest.mark.slow
def test_scores_are_deterministic_and_independent_of_jobs(reference: tuple[Path, Path]) -> None:
    ref, root = reference
    out = root / "jobs2"
    assert main(["bench", "dlqr", "hodosmc", "--definition", str(root / "small.toml"), "--jobs",
                 "2", "--out", str(out)]) == 0  # fmt: skip
    for name in ("results.parquet", "scores.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(ref / name), pd.read_parquet(out / name),
                                      check_exact=True)  # fmt: skip
    for name in ("index.html", "leaderboard.png", "levels.png"):
        assert (out / name).stat().st_size > 1000
    # a rerun of a finished benchmark runs nothing and gives the same scores
    assert main(["bench", "dlqr", "hodosmc", "--definition", str(root / "small.toml"),
                 "--out", str(out)]) == 0  # fmt: skip
    pd.testing.assert_frame_equal(pd.read_parquet(ref / "scores.parquet"),
                                  pd.read_parquet(out / "scores.parquet"), check_exact=True)


def test_an_interrupted_run_continues_to_the_same_scores(reference: tuple[Path, Path]) -> None:
    ref, root = reference
    out = root / "resumed"
    w = BenchRun(load_bench(str(root / "small.toml")), resolve_entrants(["dlqr", "hodosmc"]))
    calls = []

    def stop_after_first(done: int, total: int, elapsed: float) -> None:
        calls.append(done)
        raise KeyboardInterrupt  # Ctrl-C right after the first chunk was saved

    first = run_bench(w, out, jobs=1, progress=stop_after_first)
    assert first.status == "interrupted" and 0 < first.blocks_run < first.blocks_total
    assert not (out / "scores.parquet").exists() and not (out / "results.parquet").exists()
    second = run_bench(w, out, jobs=1, progress=quiet)
    assert second.status == "done"
    assert second.blocks_run == first.blocks_total - first.blocks_run  # no block run twice
    for name in ("results.parquet", "scores.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(ref / name), pd.read_parquet(out / name),
                                      check_exact=True)  # fmt: skip


@pytest.mark.slow
def test_kill_9_then_rerun_gives_the_same_scores(tmp_path: Path) -> None:
    """SIGKILL `mwip bench` once a chunk is saved; the same command continues to the scores of
    an uninterrupted run."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from mwip.campaign.execute import done_blocks

    definition = tmp_path / "many.toml"  # 8 levels x 12 runs in blocks of 4: 24 blocks
    definition.write_text(SMALL.replace("samples = 3", "samples = 12"))
    w = BenchRun(load_bench(str(definition)), resolve_entrants(["dlqr"]))
    run_bench(w, tmp_path / "ref", jobs=1, progress=quiet)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mwip", "bench", "dlqr", "--definition", str(definition),
           "--jobs", "1", "--out", str(out)]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 240
    while not done_blocks(out) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    if len(done_blocks(out)) == 24:  # every chunk was saved before the kill landed
        pytest.skip("the run finished its chunks before SIGKILL")
    assert done_blocks(out) and not (out / "scores.parquet").exists()
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    for name in ("results.parquet", "scores.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "ref" / name),
                                      pd.read_parquet(out / name), check_exact=True)


# ---- the scores ---------------------------------------------------------------------------------
def test_scores_table_rows_and_wilson_intervals(reference: tuple[Path, Path]) -> None:
    ref, _ = reference
    s = pd.read_parquet(ref / "scores.parquet")
    b = parse_bench(tomllib.loads(SMALL))
    assert len(s) == 2 * (len(b.levels) + len(b.axes))  # levels, plus one pooled row per axis
    assert set(s["controller"]) == {"dlqr", "hodosmc"}
    for _, row in s.iterrows():
        assert row["n"] == b.samples * (len(next(a for a in b.axes if a.name == row["axis"]).levels)
                                        if row["level"] == POOLED else 1)  # fmt: skip
        assert (row["wilson_lo"], row["wilson_hi"]) == wilson(row["successes"], row["n"])
        assert row["fraction"] == row["successes"] / row["n"]
    for col in ("median_rms_theta", "median_rms_speed_error", "median_control_tv",
                "median_peak_torque"):  # fmt: skip
        assert col in s
    res = pd.read_parquet(ref / "results.parquet")
    assert len(res) == 2 * len(b.levels) * b.samples


def test_a_level_without_effects_repeats_the_nominal_runs(reference: tuple[Path, Path]) -> None:
    """A zero push and noise x1 change nothing: replicate i of each repeats nominal replicate
    i exactly (common random numbers). (The posterior level draws the packaged posterior's
    members, :func:`test_the_posterior_level_draws_the_packaged_members`.)"""
    ref, _ = reference
    res = pd.read_parquet(ref / "results.parquet")
    cols = ["success", "status", "rms_theta", "rms_speed_error", "peak_torque", "control_tv"]
    for c in ("dlqr", "hodosmc"):
        mine = res[res["controller"] == c]
        nominal = mine[mine["axis"] == "nominal"].sort_values("replicate")[cols]
        for level in ("push 0", "noise x1"):
            other = mine[mine["level"] == level].sort_values("replicate")[cols]
            pd.testing.assert_frame_equal(nominal.reset_index(drop=True),
                                          other.reset_index(drop=True), check_exact=True)
        assert nominal["success"].all()  # the book's controllers balance the nominal twin
        hard = mine[mine["axis"] == "hard"]
        assert not np.allclose(hard["rms_theta"].to_numpy()[:3], nominal["rms_theta"].to_numpy())


def test_the_posterior_level_draws_the_packaged_members(reference: tuple[Path, Path]) -> None:
    """The ``posterior`` level's twins are members of the identified twin's posterior
    (``book-twin.json``: resampled from the book calibration's posterior), inside the
    prior's box, and not all the default twin: its runs differ from the nominal ones."""
    import json

    from mwip.bench.run import posterior_members
    from mwip.hardware.identified import STATUS_FILE

    doc = json.loads(STATUS_FILE.read_text(encoding="utf-8"))
    members = posterior_members()
    assert len(members) == len(doc["members"]) > 1
    from mwip.hardware.prior import current_name

    # the record names the unknowns as the calibration's run did; the members are the
    # prior's unknowns by their names now (mwip.hardware.prior.LEGACY_NAMES)
    box = {current_name(k): b
           for k, b in zip(doc["prior"]["names"], doc["prior"]["bounds"], strict=True)}
    from mwip.hardware.identified import default_twin

    known = default_twin().values()
    for m in members:
        # every unknown of the robot now; those the calibration did not vary (declared after
        # it, e.g. firmware.torque_gain) at the default twin's value
        assert set(m) == set(known) and set(box) <= set(m)
        assert all(box[k][0] <= m[k] <= box[k][1] for k in box)
        assert all(m[k] == known[k] for k in set(known) - set(box))
    ref, _ = reference
    res = pd.read_parquet(ref / "results.parquet")
    mine = res[res["controller"] == "dlqr"]
    nominal = mine[mine["axis"] == "nominal"].sort_values("replicate")["rms_theta"]
    post = mine[mine["level"] == "posterior"].sort_values("replicate")["rms_theta"]
    assert len(post) == len(nominal) and not np.array_equal(post.to_numpy(), nominal.to_numpy())


class _NoTorque:
    """A controller that never acts: the robot falls from any tilt."""

    Ts = 0.005
    static = False

    def reset(self, meas: Measurement) -> None:
        return None

    def __call__(self, t: float, meas: Measurement) -> np.ndarray:
        return np.zeros((meas.y.shape[0], 2))

    def log(self) -> dict[str, np.ndarray]:
        return {}


def test_a_controller_that_cannot_balance_scores_zero(tmp_path: Path) -> None:
    from mwip.laws.registry import CONTROLLERS, ControllerSpec, register

    register(ControllerSpec("no-torque", "u = 0", "test", (), lambda nom, s, Ts: _NoTorque()))
    try:
        definition = tmp_path / "long.toml"  # long enough to fall from any start: 4 s
        definition.write_text(SMALL.replace("duration = 0.6", "duration = 4.0"))
        w = BenchRun(load_bench(str(definition)), resolve_entrants(["no-torque", "dlqr"]))
        run_bench(w, tmp_path / "out", jobs=1, progress=quiet)
    finally:
        CONTROLLERS.pop("no-torque")
    s = pd.read_parquet(tmp_path / "out" / "scores.parquet")
    none = s[s["controller"] == "no-torque"]
    assert len(none) == len(s) // 2 and (none["successes"] == 0).all()
    assert (none["wilson_lo"] == 0).all() and (none["fraction"] == 0).all()
    assert none["median_rms_theta"].isna().all()  # no successful run to take a median over
    res = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert (res[res["controller"] == "no-torque"]["status"] == "fell").all()
    assert (s[(s["controller"] == "dlqr") & (s["axis"] == "nominal")]["fraction"] == 1).all()
    assert "no-torque" in (tmp_path / "out" / "index.html").read_text()


# ---- entrants and the settings file -----------------------------------------------------------
def test_settings_file_round_trip_and_entrants(tmp_path: Path) -> None:
    path = write_settings_file(tmp_path / "best.toml", "hodosmc", {"K": [7.125, 3.5], "phi": 0.1},
                               "tuned by mwip tune\nseed 0", label="hodosmc-tuned")  # fmt: skip
    sf = read_settings_file(path)
    assert sf.name == "hodosmc" and sf.label == "hodosmc-tuned"
    assert sf.settings_dict() == {"K": [7.125, 3.5], "phi": 0.1}
    assert path.read_text().startswith("# tuned by mwip tune\n# seed 0\n[controller]")
    scenario = Path(__file__).resolve().parents[1] / "examples" / "balance.toml"
    ents = resolve_entrants(["dlqr"], [path], [scenario])
    assert [e.label for e in ents] == ["dlqr", "hodosmc-tuned", "balance"]
    assert ents[1].settings_dict() == {"K": (7.125, 3.5), "phi": 0.1}
    assert len(resolve_entrants([])) >= 10  # every registered controller by default
    with pytest.raises(ValueError, match="settings"):
        settings_text("smc", {"K": [float("nan"), 1.0]})


# ---- bad input: exit 2, one line, nothing written ---------------------------------------------
def _bad_files(tmp_path: Path) -> dict[str, Path]:
    files = {}
    for name, text in {
        "range": '[controller]\nname = "hodosmc"\n[settings]\nK = [-1.0, 2.0]\n',
        "key": '[controller]\nname = "hodosmc"\n[settings]\nspeed = 1.0\n',
        "name": '[controller]\nname = "nope"\n',
        "table": '[controller]\nname = "smc"\n[extra]\n',
        "toml": '[controller\n',
    }.items():  # fmt: skip
        files[name] = tmp_path / f"{name}.toml"
        files[name].write_text(text)
    bad_def = tmp_path / "def.toml"
    bad_def.write_text(SMALL.replace("seed = 5", "seed = 5\nspeed = 3"))
    files["def"] = bad_def
    return files


@pytest.mark.parametrize(("args", "needle"), [
    (["nope"], "unknown controller 'nope'"),
    (["--settings", "{range}"], "setting 'K'"),
    (["--settings", "{key}"], "no setting 'speed'"),
    (["--settings", "{name}"], "unknown controller 'nope'"),
    (["--settings", "{table}"], "unknown table 'extra'"),
    (["--settings", "{toml}"], "settings file"),
    (["--settings", "{missing}"], "settings file"),
    (["--scenario", "{missing}"], "scenario"),
    (["--samples", "0"], "--samples"),
    (["--jobs", "0"], "--jobs"),
    (["--definition", "{def}"], "bench.speed"),
    (["dlqr", "dlqr"], "entered twice"),
])  # fmt: skip
def test_bad_input_exits_2_with_one_line_and_writes_nothing(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], args: list[str], needle: str
) -> None:
    files = {k: str(v) for k, v in _bad_files(tmp_path).items()}
    files["missing"] = str(tmp_path / "missing.toml")
    out = tmp_path / "out"
    argv = ["bench", *(a.format(**files) for a in args), "--quick", "--out", str(out)]
    assert main(argv) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not out.exists()


def test_out_that_holds_another_benchmark_is_refused(tmp_path: Path,
                                                     capfd: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    definition = str(small(tmp_path))
    assert main(["bench", "dlqr", "--definition", definition, "--jobs", "1", "--out",
                 str(out)]) == 0  # fmt: skip
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    capfd.readouterr()
    assert main(["bench", "hodosmc", "--definition", definition, "--jobs", "1", "--out",
                 str(out)]) == 2  # fmt: skip
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "different campaign" in err
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_show_prints_the_builtin_definition(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "--show"]) == 0
    text = capsys.readouterr().out
    assert text == builtin_text()
    assert parse_bench(tomllib.loads(text)).levels == load_bench().levels
