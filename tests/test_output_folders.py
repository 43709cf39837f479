"""Output folders (issue 25): each command writes into a folder of its own, never into one
another command owns unless told to (--force), says where it wrote, and a study run on
another robot says so in its report section."""

from __future__ import annotations

import json

import pytest

from mwip import outdir
from mwip.cli import main


@pytest.fixture
def tiny_studies(monkeypatch):
    """Two one-second studies in place of the book's (the registry's discovery replaced)."""
    from mwip.studies import registry
    from mwip.studies.study import Study, save_study

    def run(ctx):
        return save_study(ctx, metrics={"a.x": 1.0},
                          claims=[{"id": "x", "text": "x", "holds": True, "book": False,
                                   "keys": ["a.x"]}],
                          runs={"a": {"status": "ok"}},
                          settings={"plant": ctx.plant_label})  # fmt: skip

    declared = {n: Study(n, "test", run, place=(i,)) for i, n in enumerate(["one", "two"])}
    monkeypatch.setattr(registry, "_discover", lambda: declared)


def _tree(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}  # fmt: skip


def test_run_never_writes_into_reproduces_folder(tmp_path, capsys, tiny_studies, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--out", "out", "--no-compare", "-j", "1"]) == 0
    assert outdir.owner(tmp_path / "out") == "reproduce"
    before = _tree(tmp_path / "out")
    capsys.readouterr()
    robot = tmp_path / "robot.toml"
    robot.write_text("[params]\nmb = 25.0\n")
    # into reproduce's folder: refused, one line, exit 2, nothing changed
    assert main(["run", "one", "--robot", str(robot), "--out", "out"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds the results of `mwip reproduce`" in err
    assert "--force" in err and _tree(tmp_path / "out") == before
    # by default: a folder of its own, said where
    assert main(["run", "one", "--robot", str(robot), "-j", "1", "-v"]) == 0
    cap = capsys.readouterr()
    assert "report: runs/one/index.html" in cap.out
    assert _tree(tmp_path / "out") == before
    assert outdir.owner(tmp_path / "runs" / "one") == "run"
    record = json.loads((tmp_path / "runs" / "one" / "run.json").read_text())
    assert record["studies"]["one"]["robot"] == f"robot {robot}"
    html = (tmp_path / "runs" / "one" / "index.html").read_text()
    assert f"<h2>one: one (on robot {robot})</h2>" in html
    assert "; on robot " in cap.out  # the summary line (clipped to the width)
    # several studies: their names; reproduce refuses run's folder too
    assert main(["run", "one", "two", "-j", "1"]) == 0
    assert (tmp_path / "runs" / "one+two" / "two" / "metrics.json").is_file()
    assert main(["reproduce", "--out", "runs/one", "--no-compare"]) == 2
    assert "holds the results of `mwip run`" in capsys.readouterr().err
    # --force: written, and the folder stays reproduce's
    assert main(["run", "two", "--out", "out", "--force", "-j", "1"]) == 0
    assert outdir.owner(tmp_path / "out") == "reproduce"
    assert main(["simulate", "--duration", "0.1", "--out", "out"]) == 2
    assert "`mwip reproduce`" in capsys.readouterr().err


def test_book_robot_run_has_no_robot_note(tmp_path, capsys, tiny_studies):
    # the book's robot: no --robot (it replaces --params real)
    assert main(["run", "one", "--out", str(tmp_path / "o"), "-j", "1"]) == 0
    record = json.loads((tmp_path / "o" / "run.json").read_text())
    assert "robot" not in record["studies"]["one"]
    assert "<h2>one: one</h2>" in (tmp_path / "o" / "index.html").read_text()


def test_marker_names_its_owner(tmp_path):
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    (legacy / outdir.MARKER).write_text(outdir.MARKER_TEXT)  # an older mwip: no command
    (legacy / "x").write_text("")
    assert outdir.owner(legacy) is None
    assert outdir.check(legacy, command="run") == legacy  # any command's
    outdir.claim(legacy, "run")
    assert outdir.owner(legacy) == "run"
    with pytest.raises(ValueError, match="holds the results of `mwip run`"):
        outdir.check(legacy, command="reproduce")
    assert outdir.check(legacy, command="run") == legacy
    assert outdir.check(legacy, force=True, command="reproduce") == legacy
    assert outdir.check(legacy) == legacy  # no command named: any mwip folder
    outdir.claim(legacy, "reproduce")  # a folder keeps its owner
    assert outdir.owner(legacy) == "run"


@pytest.mark.parametrize("command", ["simulate", "run", "reproduce"])
def test_help_says_where_results_go(command, capsys):
    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    expected = {"simulate": "default: none, nothing is written",
                "run": "default: runs/<STUDY>", "reproduce": "default: out"}[command]  # fmt: skip
    assert expected in text


def test_export_and_campaign_refuse_a_results_folder(tmp_path, capsys):
    out = tmp_path / "out"
    outdir.claim(out, "reproduce")
    (out / "run.json").write_text("{}")
    before = _tree(out)
    assert main(["export", "c", "--controller", "lqr", "--out", str(out)]) == 2
    assert "holds the results of `mwip reproduce`" in capsys.readouterr().err
    assert main(["campaign", "run", "robustness", "--samples", "1", "--out", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert _tree(out) == before
