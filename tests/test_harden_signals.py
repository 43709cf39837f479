"""Hardening (issue 26, item 8): Ctrl-C while the CLI is being imported exits 130 without a
traceback; Dask workers ignore the terminal's Ctrl-C (the main process stops them in order)
and log only errors; a second ``mwip reproduce`` (or ``campaign run``) into a folder that a
running one holds is refused, and a lock left by a killed run is taken over."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mwip.cli import main
from mwip.outdir import LOCK, MARKER, hold
from mwip.studies import registry
from mwip.studies.study import Study, save_study

ROOT = Path(__file__).resolve().parent.parent


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT / "src"))


def test_ctrl_c_while_importing_the_cli_exits_130_quietly():
    """SIGINT arrives exactly while ``mwip.cli`` is being imported (a meta-path hook sends
    it): no timing involved."""
    code = (
        "import os, signal, sys\n"
        "class Hook:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'mwip.cli':\n"
        "            os.kill(os.getpid(), signal.SIGINT)\n"
        "        return None\n"
        "sys.meta_path.insert(0, Hook())\n"
        "sys.argv = ['mwip', '--help']\n"
        "from mwip.console import entry\n"
        "entry()\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_env(), timeout=120)  # fmt: skip
    assert res.returncode == 130, res
    assert "Traceback" not in res.stderr and "KeyboardInterrupt" not in res.stderr


def test_python_m_mwip_and_the_console_script_share_the_entry():
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["mwip"] == "mwip.console:entry"
    assert "mwip.console" in (ROOT / "src" / "mwip" / "__main__.py").read_text()


def _probe_child(q) -> None:  # (module level: a spawned process imports it)
    import os
    import signal

    q.put((signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []),
           os.environ.get("DASK_LOGGING__DISTRIBUTED")))  # fmt: skip


def test_dask_workers_are_started_deaf_to_ctrl_c_and_quiet():
    """Issue 39: the workers start with SIGINT blocked (they never see the terminal's
    Ctrl-C) while this process keeps its own handler all along (a Ctrl-C during the start is
    not dropped, as it was with SIG_IGN)."""
    import multiprocessing
    import signal

    from mwip.campaign.execute import _quiet_workers

    ctx = multiprocessing.get_context("spawn")
    q = ctx.Queue()
    handler_during: list = []

    def start():
        handler_during.append(signal.getsignal(signal.SIGINT))
        p = ctx.Process(target=_probe_child, args=(q,))
        p.start()
        got = q.get(timeout=60)
        p.join(60)
        return got

    before = os.environ.get("DASK_LOGGING__DISTRIBUTED")
    handler = signal.getsignal(signal.SIGINT)
    assert _quiet_workers(start) == (True, "error")
    assert handler_during == [handler] and handler is not signal.SIG_IGN  # never ignored here
    assert os.environ.get("DASK_LOGGING__DISTRIBUTED") == before  # restored here
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])


@pytest.fixture
def fake_studies(monkeypatch):
    def run(ctx):
        claim = {"id": "x", "text": "x", "holds": True, "book": False, "keys": ["a.x"]}
        return save_study(ctx, metrics={"a.x": 1.0}, claims=[claim],
                          runs={"a": {"status": "ok"}}, settings={})  # fmt: skip

    declared = {"good": Study("good", "x", run, place=(1,))}
    monkeypatch.setattr(registry, "_discover", lambda: declared)


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


def test_a_second_reproduce_into_a_held_folder_is_refused(tmp_path, capsys, fake_studies):
    out = tmp_path / "out"
    with hold(out):
        assert main(["reproduce", "--out", str(out), "-j", "1", "--no-compare"]) == 2
        line = _err_line(capsys)
        assert "--out" in line and "in use" in line and f"process {os.getpid()}" in line
        assert not (out / "good").exists()
    assert main(["reproduce", "--out", str(out), "-j", "1", "--no-compare"]) == 0
    assert (out / "good" / "metrics.json").is_file() and not (out / LOCK).exists()


def test_a_lock_held_by_another_process_is_refused(tmp_path, capsys, fake_studies):
    out = tmp_path / "out"
    code = ("import sys; from mwip.outdir import hold\n"
            f"with hold({str(out)!r}):\n"
            "    print('held', flush=True); sys.stdin.read()\n")  # fmt: skip
    child = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=_env())  # fmt: skip
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == "held"
        assert main(["reproduce", "--out", str(out), "-j", "1", "--no-compare"]) == 2
        assert f"process {child.pid}" in _err_line(capsys)
    finally:
        assert child.stdin is not None
        child.stdin.close()
        child.wait(timeout=60)
    assert main(["reproduce", "--out", str(out), "-j", "1", "--no-compare"]) == 0


def test_a_stale_lock_of_a_killed_run_is_taken_over(tmp_path, fake_studies):
    out = tmp_path / "out"
    out.mkdir()
    (out / MARKER).write_text("x")
    (out / LOCK).write_text("999999999\n")  # its process is gone: nothing holds the lock
    assert main(["reproduce", "--out", str(out), "-j", "1", "--no-compare"]) == 0
    assert not (out / LOCK).exists()


def test_a_second_campaign_run_is_refused_and_a_refusal_leaves_no_folder(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text('[campaign]\nsamples = 2\nblock = 2\nduration = 0.2\nsensors = "ideal"\n'
                    '[[controllers]]\nname = "lqr"\n')  # fmt: skip
    out = tmp_path / "out"
    with hold(out):
        assert main(["campaign", "run", str(path), "--out", str(out), "--jobs", "1"]) == 2
        assert "in use" in _err_line(capsys)
    assert not out.exists()  # created by the test's hold, removed again when empty
    assert main(["campaign", "run", str(path), "--out", str(out), "--jobs", "1"]) == 0
    assert not (out / LOCK).exists()
