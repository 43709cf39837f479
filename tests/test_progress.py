"""Progress and notices (issue 25): runs done / total within a study, the share of the work
and the time left across studies, one-line notices before first-use work, and `mwip list`
without importing any study module."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mwip.cli import main
from mwip.studies.progress import StudyProgress, duration_text


def test_progress_lines_within_a_study_are_printed(tmp_path, capsys, monkeypatch):
    """Captured (not a terminal): the runs of a study as they end, then with the total the
    study made last time, and one line per finished study with the share of the work."""
    from mwip.studies import runner

    monkeypatch.setattr(runner, "_counts_file", lambda: tmp_path / "runs.json")  # none yet
    args = ["run", "lqr-gain", "--quick", "-j", "1", "--out", str(tmp_path / "o")]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "lqr-gain: 1 run done (its total is known after it has run once here)" in err
    assert "lqr-gain: 2 runs done" in err
    assert "studies 1/1 (100% of the work" in err and "lqr-gain done in" in err
    assert main([*args, "--force"]) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("lqr-gain: ")]
    assert lines == ["lqr-gain: 1/3 runs (33%)", "lqr-gain: 2/3 runs (66%)",
                     "lqr-gain: 3/3 runs (100%)"]  # fmt: skip
    assert "lqr-gain done in" in err and "3/3 runs" in err
    assert runner.expected_runs(["lqr-gain", "exp-it2"], True) == {"lqr-gain": 3, "exp-it2": None}
    assert runner.expected_runs(["lqr-gain"], False) == {"lqr-gain": None}  # per mode


def test_share_of_the_work_and_time_left():
    now = [0.0]
    p = StudyProgress(["a", "b"], {"a": 1.0, "b": 3.0}, {"a": 10, "b": None}, clock=lambda: now[0])
    assert p.left() is None
    lines = [p.run("a") for _ in range(10)]
    assert lines[0] == "a: 1/10 runs (10%)" and lines[-1] == "a: 10/10 runs (100%)"
    assert p.fraction() == pytest.approx(0.99 / 4)  # a running study counts at most 99 %
    now[0] = 10.0
    line = p.done("a", 10.0)
    assert p.fraction() == pytest.approx(0.25)
    assert line == ("studies 1/2 (25% of the work, 10 s so far, about 30 s left): "
                    "a done in 10.0 s, 10/10 runs")  # fmt: skip
    shown = [p.run("b") for _ in range(20)]
    assert [i + 1 for i, s in enumerate(shown) if s] == [1, 2, 5, 10, 20]  # total unknown
    assert p.status() == "1/2 studies; b 20 runs"
    assert "FAILED" in p.done("b", 1.0, error="x") and p.fraction() == 1.0
    assert duration_text(185) == "3 min 05 s" and duration_text(3720) == "1 h 02 min"


def test_notice_is_printed_once_and_can_be_silenced(capsys, monkeypatch):
    from mwip import notice

    monkeypatch.setenv("MWIP_NOTICES", "on")  # off for the rest of the suite (conftest.py)
    monkeypatch.setattr(notice, "_SHOWN", set())
    assert notice.once("k", "compiling (once)") and not notice.once("k", "compiling (once)")
    assert capsys.readouterr().err == "mwip: compiling (once)\n"
    monkeypatch.setenv("MWIP_NOTICES", "off")
    assert not notice.once("k2", "x") and capsys.readouterr().err == ""


def test_jit_notice_before_a_first_compilation(capsys, monkeypatch):
    """The batch loop's notice when Numba has neither compiled it here nor cached it on disk."""
    from mwip import notice
    from mwip.sim import engine

    class Fresh:
        __name__ = "run_parallel"
        signatures: list = []

        class _cache:  # noqa: N801 - Numba's attribute names
            class _cache_file:  # noqa: N801
                @staticmethod
                def _load_index():
                    return {}

    monkeypatch.setenv("MWIP_NOTICES", "on")
    monkeypatch.setattr(notice, "_SHOWN", set())
    engine._compile_notice(Fresh(), "the threaded batch loop")
    err = capsys.readouterr().err
    assert err.startswith("mwip: compiling the threaded batch loop") and "once" in err
    Fresh.signatures = ["compiled"]
    monkeypatch.setattr(notice, "_SHOWN", set())
    engine._compile_notice(Fresh(), "the threaded batch loop")
    assert capsys.readouterr().err == ""


def test_list_reads_the_declarations_without_importing_studies():
    """`mwip list` and name checks read the study modules' source: the same studies, sources,
    places and costs as importing them, and no NumPy, Matplotlib or study module loaded."""
    from mwip.studies import registry

    assert [tuple(d) for d in registry.declared()] == [
        (s.name, s.source, s.place, float(s.cost)) for s in registry.all_studies()
    ]
    probe = ("import sys; from mwip.cli import main; code = main(['list']); "
             "assert code == 0, code; "
             "print([m for m in sys.modules if m in ('numpy', 'matplotlib') "
             "or m.startswith('mwip.studies.') and m not in ('mwip.studies.registry', "
             "'mwip.studies.settings')])")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.splitlines()  # fmt: skip
    assert out[0].startswith("do-comparison") and out[-1] == "[]"


def test_pycc_pending_deprecation_reaches_no_user():
    """Issue 40: Numba's pending deprecation of numba.pycc is not shown, whatever the warning
    filters (``-W always``), when the ahead-of-time build imports it; the README says what the
    build stands on."""
    import os

    code = "from mwip.sim import aot; aot._import_pycc(); import numba.pycc"
    env = {**os.environ, "MWIP_NOTICES": "on"}
    err = subprocess.run([sys.executable, "-W", "always", "-c", code], capture_output=True,
                         text=True, env=env, check=True).stderr  # fmt: skip
    assert "pycc" not in err and "eprecat" not in err, err
