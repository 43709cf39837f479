"""Hardening (issue 26, item 1): the ahead-of-time module in the cache is verified before it is
loaded. A truncated, empty, garbage or folder entry, or one without its manifest, is never
imported (a truncated shared object dies by SIGBUS): ``kernels status`` calls it corrupt, a run
and ``kernels build`` rebuild it, and no temporary folder is left behind.

The toolchain is stood in for by a copy of the session's real module (a real build takes
~20 s); the real build is exercised by tests/test_aot.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import pytest

from mwip.cli import main
from mwip.sim import aot

SRC = str(Path(__file__).resolve().parent.parent / "src")


@pytest.fixture(scope="module")
def good() -> tuple[bytes, str]:
    """The session's real module and manifest (built once, shared with tests/test_aot.py)."""
    path = aot.build()
    return path.read_bytes(), aot.manifest_path().read_text()


@pytest.fixture
def cache(tmp_path, monkeypatch, good):
    """A private cache holding a sound copy of the module; builds copy it (and are counted)."""
    folder = tmp_path / "cache"
    folder.mkdir()
    monkeypatch.setenv("MWIP_CACHE_DIR", str(folder))
    monkeypatch.setenv("MWIP_AOT", "on")
    monkeypatch.setattr(aot, "_LOADED", {})
    monkeypatch.setattr(aot, "LAST_ERROR", None)
    monkeypatch.setattr(aot, "_WARNED", [False])
    aot.module_path().write_bytes(good[0])
    aot.manifest_path().write_text(good[1])
    builds: list[str] = []

    def fake_compile(name, out):
        builds.append(name)
        tempfile.mkdtemp()  # as Numba's compiler probe does, never removing it
        (out / aot.module_path().name).write_bytes(good[0])

    monkeypatch.setattr(aot, "_compile", fake_compile)
    return folder, builds


def _corrupt(how: str, good: bytes) -> None:
    path = aot.module_path()
    if how == "truncated":
        path.write_bytes(good[:1000])
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "garbage":  # the same size: only the hash tells
        path.write_bytes(bytes(b ^ 0x5A for b in good))
    elif how == "directory":
        path.unlink()
        path.mkdir()
        (path / "x").write_text("x")
    elif how == "no manifest":
        aot.manifest_path().unlink()
    elif how == "bad manifest":
        aot.manifest_path().write_text("{not json")
    else:
        raise AssertionError(how)


CASES = ("truncated", "empty", "garbage", "directory", "no manifest", "bad manifest")


def _only_the_entry(folder) -> None:
    names = sorted(p.name for p in folder.iterdir())
    stem = aot.module_path().name.split(".")[0]
    assert names == sorted([aot.module_path().name, f"{stem}.lock", f"{stem}.sha256"]), names


@pytest.mark.parametrize("how", CASES)
def test_status_calls_a_corrupt_module_corrupt(how, cache, good, capsys):
    _corrupt(how, good[0])
    assert main(["kernels", "status", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["built"] is False and info["state"].startswith("corrupt")
    assert main(["kernels", "status"]) == 0
    assert "compiled loop: corrupt" in capsys.readouterr().out


@pytest.mark.parametrize("how", CASES)
def test_a_run_rebuilds_a_corrupt_module_and_leaves_no_temporary_folder(how, cache, good):
    folder, builds = cache
    _corrupt(how, good[0])
    before = set(os.listdir(tempfile.gettempdir()))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no fallback notice: the rebuild worked
        run = aot.run_function()
    assert run is not None and builds == [aot.module_path().stem.split(".")[0]]
    assert aot.verify() is None and aot.status()["built"]
    _only_the_entry(folder)
    assert set(os.listdir(tempfile.gettempdir())) <= before


@pytest.mark.parametrize("how", CASES)
def test_kernels_build_rebuilds_a_corrupt_module_only(how, cache, good, capsys):
    folder, builds = cache
    assert main(["kernels", "build"]) == 0 and builds == []  # sound: kept
    _corrupt(how, good[0])
    assert main(["kernels", "build"]) == 0 and len(builds) == 1
    assert aot.verify() is None
    _only_the_entry(folder)


def test_load_only_mode_says_once_and_runs_the_jit_loop(cache, good, monkeypatch):
    folder, builds = cache
    _corrupt("garbage", good[0])
    monkeypatch.setenv("MWIP_AOT", "load")
    with pytest.warns(UserWarning, match="corrupt.*using the JIT loop"):
        assert aot.run_function() is None
    assert builds == []


def test_a_failed_rebuild_falls_back_with_one_notice(cache, good, monkeypatch):
    _corrupt("truncated", good[0])

    def no_compiler(name, out):
        raise OSError("no C compiler")

    monkeypatch.setattr(aot, "_compile", no_compiler)
    with pytest.warns(UserWarning, match="no C compiler; using the JIT loop"):
        assert aot.run_function() is None
    assert not [p for p in cache[0].iterdir() if ".build-" in p.name]


def test_a_truncated_module_is_not_imported(cache, good):
    """The issue's case exactly: ``truncate -s 1000`` made every run die by SIGBUS (exit 135).
    In a subprocess, so that a regression cannot take the test session down with it."""
    _corrupt("truncated", good[0])
    env = dict(os.environ, MWIP_AOT="load", PYTHONPATH=SRC)
    code = "from mwip.sim import aot; print(aot.run_function() is None)"
    res = subprocess.run([sys.executable, "-W", "always", "-c", code], capture_output=True,
                         text=True, env=env, timeout=120)  # fmt: skip
    assert res.returncode == 0, res
    assert res.stdout.strip() == "True" and "corrupt" in res.stderr


@pytest.mark.slow
def test_a_damaged_numba_cache_entry_is_a_miss(tmp_path):
    """Numba's own cache of mwip's kernels: a truncated index or a garbage data file raised
    ``UnpicklingError`` from inside every later run (an internal error); it is now a miss, the
    kernel compiled again and the entry rewritten."""
    env = dict(os.environ, MWIP_CACHE_DIR=str(tmp_path / "nb"), PYTHONPATH=SRC)
    code = ("from mwip.fuzzy._kernel import _tri; "
            "print(_tri(0.5, 0.0, 1.0, 2.0), sum(_tri.stats.cache_hits.values()))")  # fmt: skip

    def run() -> list[str]:
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, timeout=300)  # fmt: skip
        assert res.returncode == 0, res.stderr[-2000:]
        return res.stdout.split()

    assert run() == ["0.5", "0"]  # compiled and written
    (index,) = (tmp_path / "nb").rglob("_kernel._tri-*.nbi")
    index.write_bytes(index.read_bytes()[:10])
    assert run() == ["0.5", "0"]  # a miss, not an UnpicklingError; written again
    for data in (tmp_path / "nb").rglob("_kernel._tri-*.nbc"):
        data.write_bytes(b"garbage")
    assert run() == ["0.5", "0"]  # a miss again
    assert run() == ["0.5", "1"]  # and a hit: the rewritten entry is sound


def test_the_cli_says_the_fallback_in_one_line(tmp_path):
    """An unusable cache folder: the run works on the JIT loop and says so in one line (not
    Python's warning with its file, line number and source line)."""
    (tmp_path / "file").write_text("x")
    env = dict(os.environ, MWIP_CACHE_DIR=str(tmp_path / "file" / "cache"), MWIP_AOT="on",
               PYTHONPATH=SRC)
    res = subprocess.run([sys.executable, "-m", "mwip", "simulate", "--duration", "0.1",
                          "--out", str(tmp_path / "o")], capture_output=True, text=True,
                         env=env, timeout=300)  # fmt: skip
    assert res.returncode == 0, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mwip: warning:"), lines
    assert "using the JIT loop" in lines[0] and "UserWarning" not in lines[0]
