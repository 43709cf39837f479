"""Hardening round 3 (issue 39, items 5 and 6): connections are bounded and Ctrl-C is never
lost.

- ``--scheduler``: the connection and the Dask handshake must come within the stated
  timeout; a service that accepts and never answers, an HTTP server, or one answering
  garbage (which Dask read as a 3 EiB frame: ``MemoryError``) is one line, exit 2, nothing
  written. (``tune --storage``: tests/test_harden_tune.py.)
- Ctrl-C while Dask's local cluster starts (the workers were started with SIGINT ignored,
  and so was this process meanwhile: the Ctrl-C was dropped and the run went on to exit 0)
  stops the command with exit 130, one line, no worker process left.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from mwip.campaign import execute  # noqa: E402
from mwip.campaign.execute import check_scheduler  # noqa: E402
from mwip.cli import main  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

SMALL = ('[campaign]\nsamples = 8\nblock = 2\nduration = 0.2\nsensors = "ideal"\n'
         '[[controllers]]\nname = "lqr"\n')  # fmt: skip


class _Server:
    """A local TCP server: ``answer`` (bytes, sent on accepting; ``None``: never answers)."""

    def __init__(self, answer: bytes | None) -> None:
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.answer = answer
        self.conns: list[socket.socket] = []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.answer is not None:
                try:
                    conn.sendall(self.answer)
                except OSError:
                    pass

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def close(self) -> None:
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.fixture
def server(request):
    srv = _Server(request.param)
    yield srv
    srv.close()


HTTP = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"


@pytest.mark.parametrize(
    ("server", "needle"),
    [
        (None, "gave no Dask handshake within 1 s"),  # accepts, never answers
        (HTTP, "is not a Dask scheduler (it answered b'HTTP/1.1'"),
        (b"\xff" * 64, "is not a Dask scheduler"),  # a frame of 2^64 - 1 bytes
        (b"\x10\x00\x00\x00\x00\x00\x00\x00" + b"garbage!" * 2, "not a Dask"),
        (b"SSH-2.0-OpenSSH_9.6\r\n", "is not a Dask scheduler"),
    ],
    indirect=["server"],
)
def test_a_scheduler_that_is_not_dask_is_refused_within_the_timeout(server, needle):
    t0 = time.monotonic()
    with pytest.raises(ValueError, match="--scheduler") as info:
        check_scheduler(server.address, timeout=1.0)
    assert needle in str(info.value)
    assert time.monotonic() - t0 < 60  # generous: that it ends is what is tested


@pytest.mark.parametrize(
    ("address", "needle"),
    [("", "empty"), ("   ", "empty"), ("nosuch://x:1", "unknown scheme"),
     ("tcp://127.0.0.1:1", "cannot reach"), ("tcp://127.0.0.1:notaport", "not an address")],
)  # fmt: skip
def test_bad_scheduler_addresses(address, needle):
    with pytest.raises(ValueError, match="--scheduler") as info:
        check_scheduler(address, timeout=1.0)
    assert needle in str(info.value)


def test_a_real_scheduler_passes_the_check():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        check_scheduler(cluster.scheduler_address, timeout=30.0)


@pytest.mark.parametrize("server", [None, HTTP], indirect=True)
@pytest.mark.parametrize("command", ["campaign", "bench"])
def test_the_commands_say_it_in_one_line_and_write_nothing(server, command, tmp_path, capsys,
                                                           monkeypatch):  # fmt: skip
    monkeypatch.setattr(execute, "SCHEDULER_TIMEOUT_S", 1.0)
    out = tmp_path / "out"
    if command == "campaign":
        (tmp_path / "c.toml").write_text(SMALL)
        argv = ["campaign", "run", str(tmp_path / "c.toml"), "--out", str(out)]
    else:
        argv = ["bench", "lqr", "--quick", "--samples", "1", "--out", str(out)]
    assert main([*argv, "--scheduler", server.address]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mwip: error: --scheduler"), err
    assert not out.exists()


@pytest.mark.parametrize("command", ["campaign", "bench"])
def test_an_empty_scheduler_is_refused(command, tmp_path, capsys):
    out = tmp_path / "out"
    (tmp_path / "c.toml").write_text(SMALL)
    argv = (["campaign", "run", str(tmp_path / "c.toml")] if command == "campaign"
            else ["bench", "lqr", "--quick"])  # fmt: skip
    assert main([*argv, "--out", str(out), "--scheduler", ""]) == 2
    assert "--scheduler: the address is empty" in capsys.readouterr().err
    assert not out.exists()


# ---- Ctrl-C while the local cluster starts ------------------------------------------------------
#: ``python -c HOOK ARGS``: ``mwip ARGS`` through the console entry, SIGINT sent to itself
#: from Dask's own thread right after the first worker process is spawned (the cluster is
#: then starting: the moment the old code ignored SIGINT).
HOOK = """
import os, signal, sys
from multiprocessing import util
real = util.spawnv_passfds
sent = []
def spawn(path, args, passfds):
    pid = real(path, args, passfds)
    if not sent and not any("resource_tracker" in str(a) for a in args):
        sent.append(pid)
        os.kill(os.getpid(), signal.SIGINT)
    return pid
util.spawnv_passfds = spawn
sys.argv = ["mwip", *sys.argv[1:]]
from mwip.console import entry
entry()
"""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def _descendants(pid: int) -> list[int]:
    import psutil

    try:
        return [p.pid for p in psutil.Process(pid).children(recursive=True)]
    except psutil.Error:
        return []


def test_ctrl_c_while_the_cluster_starts_is_not_lost(tmp_path):
    (tmp_path / "c.toml").write_text(SMALL.replace("samples = 8", "samples = 400"))
    out = tmp_path / "out"
    argv = ["campaign", "run", str(tmp_path / "c.toml"), "--out", str(out), "--jobs", "2"]
    proc = subprocess.Popen([sys.executable, "-c", HOOK, *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT / "src")),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    seen: set[int] = set()
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:  # the workers, while there
        seen.update(_descendants(proc.pid))
        time.sleep(0.01)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err  # before: the Ctrl-C was dropped and the run finished
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0], err
    assert not (out / "results.parquet").exists()
    deadline = time.monotonic() + 30  # generous: no worker process outlives the command
    while [p for p in seen if _alive(p)] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [p for p in seen if _alive(p)]
