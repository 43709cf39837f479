"""A newcomer's first hour (issue 40): help without arguments, no file replaced without
--force, missing extras named, Ctrl-C one line, campaigns that report within their first
block, the summary's words for one study, the folders git should ignore."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mwip.cli import main

ROOT = Path(__file__).resolve().parents[1]


# ---- 7. bare `mwip` and bare groups: their help on stdout, exit 0 -------------------------


@pytest.mark.parametrize("args", [[], ["twin"], ["campaign"], ["params"], ["kernels"]])
def test_bare_mwip_and_bare_groups_print_help_to_stdout(args, capsys):
    assert main(args) == 0
    cap = capsys.readouterr()
    assert cap.out.startswith(f"Usage: mwip {' '.join(args)}".rstrip() + " [OPTIONS] COMMAND")
    assert "Commands:" in cap.out and cap.err == ""


def test_gitignore_covers_every_default_output_folder():
    ignored = set((ROOT / ".gitignore").read_text().split())
    for folder in ("/out/", "/runs/", "/tune/", "/bench/", "/ablation/"):
        assert folder in ignored, folder


# ---- 4. single-file outputs: an existing file mwip did not write survives -----------------


def _run_dir(tmp_path: Path) -> Path:
    run = tmp_path / "run"
    assert main(["simulate", "--duration", "0.2", "--out", str(run)]) == 0
    return run


WRITERS = {
    "twin excite": lambda f, tmp: ["twin", "excite", "--out", str(f)],
    "params save": lambda f, tmp: ["params", "save", "real", str(f)],
    "scenario": lambda f, tmp: ["scenario", "asta-balance", "--out", str(f)],
    "animate": lambda f, tmp: ["animate", str(_run_dir(tmp)), "--fps", "2", "--out", str(f)],
    "plot": lambda f, tmp: ["plot", str(_run_dir(tmp)), "--out", str(f)],
}
SUFFIX = {"animate": ".gif", "plot": ".png", "twin excite": ".csv"}


@pytest.mark.parametrize("writer", list(WRITERS))
def test_a_single_file_writer_keeps_a_file_it_did_not_write(writer, tmp_path, capsys):
    target = tmp_path / f"README{SUFFIX.get(writer, '.toml')}"
    target.write_text("the user's own file\n")
    args = WRITERS[writer](target, tmp_path)
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mwip: error:") and "--force" in err[0], err
    assert target.read_text() == "the user's own file\n"
    assert main([*args, "--force"]) == 0  # named: replaced
    assert target.read_text(errors="replace") != "the user's own file\n"
    assert main(args) == 0  # a file mwip wrote (and nobody changed since): replaced again
    with open(target, "ab") as fh:
        fh.write(b"\n# edited\n")
    assert main(args) == 2  # edited since: the user's again
    assert "was changed since mwip wrote it" in capsys.readouterr().err


def test_export_keeps_a_foreign_file_of_the_same_name(tmp_path, capsys):
    board = tmp_path / "board"
    board.mkdir()
    (board / "mwip_lqr.c").write_text("my firmware\n")
    assert main(["export", "c", "--controller", "lqr", "--out", str(board)]) == 2
    assert "--force" in capsys.readouterr().err
    assert (board / "mwip_lqr.c").read_text() == "my firmware\n"


def test_a_file_in_an_mwip_folder_is_mwips(tmp_path):
    from mwip.outfile import check

    run = _run_dir(tmp_path)
    assert check(run / "timeseries.csv") == run / "timeseries.csv"
    with pytest.raises(ValueError, match="is a folder"):
        check(run)


# ---- 3. a missing extra is one line naming it, exit 2 --------------------------------------


@pytest.mark.parametrize("args", [
    ["bench", "--out", "b"], ["bench", "--out", "b", "--jobs", "1"],
    ["campaign", "run", "robustness", "--out", "r"], ["campaign", "report", "r"],
    ["twin", "calibrate", "book", "--record", "--out", "c"],
])  # fmt: skip
def test_a_missing_extra_is_one_line_naming_it(args, monkeypatch, tmp_path, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if not installed
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "optional extra 'campaign'" in err[0] and "pandas" in err[0], err
    assert "pip install -e '.[campaign]'" in err[0]
    assert not any(tmp_path.iterdir())  # nothing written


def test_a_missing_optional_package_deep_inside_is_named_too(monkeypatch, capsys):
    import click

    from mwip.cli._errors import run_guarded

    @click.command()
    def needs() -> None:
        import gymnasium  # noqa: F401

    monkeypatch.setitem(sys.modules, "gymnasium", None)
    assert run_guarded(needs, []) == 2
    err = capsys.readouterr().err
    assert "optional extra 'gym'" in err and "internal error" not in err


# ---- 1. campaigns report within their first block -------------------------------------------


def test_each_workers_first_chunk_is_one_block_and_chunks_stay_small():
    from mwip.campaign.execute import _MAX_CHUNKS, _chunks

    assert _chunks(list(range(10)), 4, first=2) == [[0], [1], [2, 3, 4, 5], [6, 7, 8, 9]]
    assert _chunks([0, 1, 2, 5, 6], 2) == [[0, 1], [2], [5, 6]]
    assert _MAX_CHUNKS >= 64


def test_the_progress_estimate_counts_only_this_runs_samples(capsys):
    from mwip.campaign.execute import _Progress

    show = _Progress(start=50)
    show(50, 100, 1.0)  # nothing run yet: no estimate
    show(60, 100, 10.0)  # 10 samples in 10 s: 40 left, about 40 s
    err = capsys.readouterr().err.splitlines()
    assert err[0].endswith("left about --") and err[1].endswith("left about 40 s")


# ---- 5. the summary for one study --------------------------------------------------------


def test_one_study_is_one_study_and_no_chapter6_verdicts_across_twins(tmp_path, capsys):
    assert main(["run", "lqr-settling", "--quick", "--jobs", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "; 1 study" in out and "1/1 study done" in out and "1 studies" not in out
    assert "judged across the identified twins" not in out


def test_report_verbose_shows_every_claim_whole_wrapped_to_the_terminal(capsys):
    from mwip.report.results import StudyResult
    from mwip.report.summary import summary_lines

    text = "a claim " * 30 + "END"
    claims = [{"id": "x", "text": text, "holds": False, "book": True, "cause": "implementation",
               "evidence": "because " * 30 + "EVIDENCE", "values": {"a.b": 1.0}}]  # fmt: skip
    doc = {"source": "src", "runs": {"a": {"status": "ok"}}, "claims": claims}
    res = StudyResult("s", Path("."), doc)

    lines = summary_lines([res], width=60, verbose=True)
    body = lines[3:-1]
    assert all(len(line) <= 60 for line in body) and len(body) > 4
    joined = " ".join(" ".join(body).split())
    assert "END" in joined and "EVIDENCE" in joined and "..." not in joined


# ---- 6. Ctrl-C is one line -------------------------------------------------------------------


CTRL_C = """
import os, signal, sys
from mwip.campaign import execute
calls = [0]
plain = execute._Progress.__call__
def hook(self, done, total, elapsed):
    plain(self, done, total, elapsed)
    calls[0] += 1
    if calls[0] == 2:  # after the first chunk: Ctrl-C at the terminal (the process group)
        os.killpg(0, signal.SIGINT)
execute._Progress.__call__ = hook
sys.argv = ["mwip", *sys.argv[1:]]
from mwip.console import entry
entry()
"""


@pytest.mark.slow
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_ctrl_c_of_a_campaign_is_one_line_exit_130(jobs, tmp_path):
    """SIGINT to the whole process group (as the terminal sends it) once the first chunk is
    saved, by a hook in the progress line: no timing involved."""
    cmd = [sys.executable, "-c", CTRL_C, "campaign", "run", "robustness", "--samples", "300",
           "--out", str(tmp_path / "r"), "--jobs", jobs]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600,
                         start_new_session=True)  # fmt: skip
    assert res.returncode == 130, res.stderr[-2000:]
    lines = [s for s in res.stderr.replace("\r", "\n").splitlines()
             if s.strip() and not s.startswith("[")]  # (the progress line)  # fmt: skip
    assert len(lines) == 1 and lines[0].startswith("mwip: interrupted;"), lines
    assert "Traceback" not in res.stderr and "Warning" not in res.stderr
