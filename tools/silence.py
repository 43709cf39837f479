"""Silence: how long a command leaves its terminal without a word (issue 40, item 1).

Runs each command in a pseudo-terminal (so that it sees a terminal, as a user's shell gives
it: progress bars draw, colours and widths are a terminal's) and records when each line of
its output appears (a line ends at ``\\n`` or ``\\r``: a progress bar redrawn in place
counts). Reports, per command, the time to its first output, the longest stretch without
output (from the start, between lines and up to its exit), the total time and the exit code.

    python tools/silence.py -- mwip simulate --duration 2            # one command
    python tools/silence.py --file commands.txt --markdown           # a list, a table
    python tools/silence.py --interrupt 5 -- mwip campaign run ...   # Ctrl-C after 5 s

``--file``: one command per line, run by ``bash -c`` in ``--cwd`` (``#`` starts a comment
line; ``label | command`` names a row). ``--fresh-cache`` gives each command a new, empty
``MWIP_CACHE_DIR`` (mwip's compiled loops and designs: a first run after installing);
without it the commands share the caller's cache (warm after the first). ``--interrupt S``
sends SIGINT to the command's process group S seconds after its start, as Ctrl-C in a
terminal does, and the report shows what it printed after that (``--tail``).

This is a benchmark, not a test: its numbers depend on the machine and its load
(BENCHMARKS.md, "Silence").
"""

from __future__ import annotations

import argparse
import contextlib
import os
import pty
import re
import select
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Timing", "run", "main"]

_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")  # a terminal's control sequences (cursor, colour)


@dataclass
class Timing:
    """What one command did: when each line came, its exit code, its last lines."""

    label: str
    command: str
    lines: list[tuple[float, str]] = field(default_factory=list)
    total: float = 0.0
    code: int | None = None
    timed_out: bool = False
    interrupted_at: float | None = None

    @property
    def first(self) -> float | None:
        """Seconds to the first output line (``None``: it printed nothing)."""
        return self.lines[0][0] if self.lines else None

    def silences(self) -> list[tuple[float, float]]:
        """``(start, length)`` of every stretch without output, the start and the end of the
        run included."""
        marks = [0.0, *(t for t, _ in self.lines), self.total]
        return [(a, b - a) for a, b in zip(marks, marks[1:], strict=False)]

    @property
    def longest(self) -> tuple[float, float]:
        """``(start, length)`` of the longest stretch without output."""
        return max(self.silences(), key=lambda s: s[1])

    def after_interrupt(self) -> list[str]:
        """The non-empty lines printed after the interrupt."""
        if self.interrupted_at is None:
            return []
        return [s for t, s in self.lines if t >= self.interrupted_at and s.strip()]


def run(command: str, *, label: str | None = None, cwd: Path | None = None,
        env: dict[str, str] | None = None, timeout: float = 3600.0,
        interrupt: float | None = None, echo: bool = False) -> Timing:  # fmt: skip
    """Run ``command`` (a ``bash -c`` line) in a pseudo-terminal and time its output lines."""
    master, slave = pty.openpty()
    os.set_blocking(master, False)
    t0 = time.perf_counter()
    proc = subprocess.Popen(["bash", "-c", command], stdin=slave, stdout=slave, stderr=slave,
                            cwd=cwd, env=env, start_new_session=True, close_fds=True)  # fmt: skip
    os.close(slave)
    res = Timing(label or command, command)
    partial = b""
    began: float | None = None  # when the pending line's first visible character came

    def take(chunk: bytes, now: float) -> None:
        nonlocal partial, began
        while chunk:
            cut = min((i for i in (chunk.find(b"\n"), chunk.find(b"\r")) if i >= 0),
                      default=-1)  # fmt: skip
            piece, chunk = (chunk, b"") if cut < 0 else (chunk[:cut], chunk[cut + 1 :])
            if began is None and _ANSI.sub("", piece.decode(errors="replace")).strip():
                began = now
            partial += piece
            if cut < 0:
                return
            text = _ANSI.sub("", partial.decode(errors="replace"))
            if text.strip() and began is not None:
                res.lines.append((began, text))
                if echo:
                    print(f"[{began:8.1f}] {text}", file=sys.stderr, flush=True)
            partial, began = b"", None

    eof = False
    while not eof:
        now = time.perf_counter() - t0
        if interrupt is not None and res.interrupted_at is None and now >= interrupt:
            res.interrupted_at = now
            with _quiet():
                os.killpg(proc.pid, signal.SIGINT)
        if now > timeout and not res.timed_out:
            res.timed_out = True
            with _quiet():
                os.killpg(proc.pid, signal.SIGKILL)
        ready, _, _ = select.select([master], [], [], 0.05)
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: the terminal's last writer has gone
                chunk = b""
            if chunk:
                take(chunk, time.perf_counter() - t0)
            else:
                eof = True
        elif proc.poll() is not None:
            # the command ended; its children may still hold the terminal: drain what is there
            try:
                chunk = os.read(master, 65536)
            except (OSError, BlockingIOError):
                chunk = b""
            if chunk:
                take(chunk, time.perf_counter() - t0)
            else:
                eof = True
    if partial.strip():
        take(b"\n", time.perf_counter() - t0)
    res.code = proc.wait()
    res.total = time.perf_counter() - t0
    os.close(master)
    return res


def _quiet() -> contextlib.suppress:
    return contextlib.suppress(ProcessLookupError, PermissionError)


def _commands(path: Path) -> list[tuple[str, str]]:
    rows = []
    for raw in path.read_text().splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        label, sep, cmd = line.partition(" | ")
        rows.append((label.strip(), cmd.strip()) if sep else (line, line))
    return rows


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def _row(t: Timing, markdown: bool) -> str:
    start, length = t.longest
    code = "timeout" if t.timed_out else str(t.code)
    if markdown:
        return (f"| `{t.label}` | {_fmt(t.first)} | {length:.1f} (at {start:.1f}) | "
                f"{t.total:.1f} | {code} |")  # fmt: skip
    return (f"{t.label}: first output {_fmt(t.first)} s, longest silence {length:.1f} s "
            f"(from {start:.1f} s), total {t.total:.1f} s, exit {code}")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module's docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, default=None, help="commands, one per line")
    ap.add_argument("--cwd", type=Path, default=None, help="working folder of the commands")
    ap.add_argument("--fresh-cache", action="store_true",
                    help="a new, empty MWIP_CACHE_DIR for each command")  # fmt: skip
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per command")
    ap.add_argument("--interrupt", type=float, default=None,
                    help="send SIGINT (Ctrl-C) this many seconds after the start")  # fmt: skip
    ap.add_argument("--markdown", action="store_true", help="one table row per command")
    ap.add_argument("--tail", type=int, default=0, help="show each command's last N lines")
    ap.add_argument("--echo", action="store_true", help="show the lines as they come")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="-- COMMAND ...")
    args = ap.parse_args(argv)
    cmd = [c for c in args.command if c != "--"] if args.command else []
    rows = _commands(args.file) if args.file else []
    if cmd:
        line = shlex.join(cmd)
        rows.append((line, line))
    if not rows:
        ap.error("give a command after -- or --file FILE")
    if args.markdown:
        print("| command | first output (s) | longest silence (s) | total (s) | exit |")
        print("|---|---|---|---|---|")
    for label, command in rows:
        env = dict(os.environ)
        tmp = None
        if args.fresh_cache:
            tmp = tempfile.TemporaryDirectory(prefix="mwip-silence-cache-")
            env["MWIP_CACHE_DIR"] = tmp.name
        t = run(command, label=label, cwd=args.cwd, env=env, timeout=args.timeout,
                interrupt=args.interrupt, echo=args.echo)  # fmt: skip
        print(_row(t, args.markdown), flush=True)
        shown = t.after_interrupt() if args.interrupt is not None else []
        if args.tail:
            shown = [s for _, s in t.lines[-args.tail :]]
        for s in shown:
            print(f"    {s}", flush=True)
        if tmp is not None:
            tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
