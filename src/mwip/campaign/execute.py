"""Running a campaign: blocks in chunks, in this process or on Dask, resumable, deterministic.

Units. A *block* (``campaign.block`` samples, aligned to the global sample index) is the
numerical unit: one engine batch per controller, sensor noise seeded from (seed, block), so a
row's numbers never depend on how the work was split (:mod:`mwip.campaign.blocks`). A *chunk*
is a whole number of consecutive blocks: one task, one Parquet file
``DIR/chunks/blocks-FIRST-LAST.parquet`` written atomically (temporary file + rename) by the
process that collects the results. Blocks past N are simulated whole and their extra rows
dropped, so the table is the same for any N that covers them.

Resuming. ``DIR/campaign.json`` records the campaign's identity (everything but N). A run
lists the chunk files present, runs only the blocks no file covers, then assembles
``DIR/results.parquet`` (atomically) from the chunk files in (controller, sample) order.
``kill -9`` at any moment loses at most the chunks in flight; a run of a finished campaign
does nothing and says so. A worker killed mid-chunk loses that chunk: Dask reruns it
elsewhere (its ``allowed-failures``).

Other work. Besides a :class:`~mwip.campaign.spec.Campaign`, the engine runs any object with
the same ``kind``, ``samples``, ``block``, ``source`` and ``identity()`` that brings its own
``compute_chunk(blocks) -> DataFrame`` and ``order_key() -> (column, order)`` (the benchmark
of :mod:`mwip.bench`; it lives above, so the engine never imports it).

Engines. ``jobs = 1`` without a scheduler runs the chunks here, one after another (the bare
batch engine). Otherwise a :class:`dask.distributed.LocalCluster` with ``jobs`` worker
processes (one thread each), or the Dask cluster at ``scheduler`` (its workers need mwip
installed; they send the rows back, so no shared file system is needed). A scheduler must
accept the connection and send Dask's handshake within :data:`SCHEDULER_TIMEOUT_S`
(:func:`check_scheduler`: a service that is not Dask is named so, exit 2).

Ctrl-C. The worker processes start with SIGINT blocked (:func:`deaf_spawns`), so the
terminal's Ctrl-C reaches only this process, never dropped (also while the cluster starts);
the workers are then killed at once (:func:`kill_children`) and the run ends within a second,
keeping the chunks written.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mwip.campaign.spec import Campaign
from mwip.io import write_json_atomic, write_parquet_atomic
from mwip.outdir import LOCK

__all__ = ["RunSummary", "compute_chunk", "run_campaign", "assemble", "done_blocks", "n_blocks",
           "check_scheduler", "deaf_spawns", "kill_children", "SCHEDULER_TIMEOUT_S", "Work",
           "work", "check_work", "MAX_HOURS"]

_CHUNK_RE = re.compile(r"^blocks-(\d{6,})-(\d{6,})\.parquet$")
#: the most chunks the default chunk size makes (one block each up to this many blocks):
#: a chunk is one task and one file, cheap beside a block's runs, and each finished chunk is
#: a line of progress (issue 40: a report within the first block, not after a quarter of
#: the work)
_MAX_CHUNKS = 256


@dataclass(frozen=True)
class RunSummary:
    """What a run did: ``status`` ``"done"``, ``"finished-before"`` or ``"interrupted"``."""

    status: str
    blocks_run: int
    blocks_total: int
    rows: int
    path: Path
    wall_s: float


def n_units(campaign: Campaign) -> int:
    """The campaign's units of work: its N samples (claims: N per study with open settings,
    interleaved; see :mod:`mwip.campaign.claims`)."""
    units = int(campaign.samples)
    if campaign.kind == "claims":
        from mwip.campaign.claims import claim_studies

        studies = claim_studies(campaign)
        if not studies:
            raise ValueError("campaign.studies: none of them declares open settings ([open])")
        units *= len(studies)
    return units


def n_blocks(campaign: Campaign) -> int:
    """Blocks needed to cover :func:`n_units` (the last one cut at it)."""
    from mwip.campaign.spec import MAX_BLOCKS

    blocks = math.ceil(n_units(campaign) / campaign.block)
    if blocks > MAX_BLOCKS:
        raise ValueError(f"campaign.samples: {blocks} blocks of campaign.block = "
                         f"{campaign.block} samples; at most {MAX_BLOCKS} (fewer samples or "
                         "larger blocks)")  # fmt: skip
    return blocks


#: Plant-seconds a second of one core simulates (BENCHMARKS.md: ~500-700 on the twin's sensors
#: and drive, ~10,000 on the plain plant): the estimate of a run's time.
PLANT_S_PER_S = {"twin": 500.0, "ideal": 10_000.0}
#: Estimated hours of one core a run may take (``max_hours``; ``--max-hours`` raises it).
MAX_HOURS = 48.0


@dataclass(frozen=True)
class Work:
    """A run's size, estimated before it starts: ``plant_s`` simulated robot-seconds (all
    samples and controllers), ``cpu_hours`` at :data:`PLANT_S_PER_S`, ``block_bytes`` the
    records of one engine batch (one per worker at a time)."""

    plant_s: float
    cpu_hours: float
    block_bytes: float


def work(campaign: Campaign) -> Work | None:
    """The size of a robustness campaign or a benchmark (``None`` for other kinds: a claims
    or calibration sample is a whole study run, bounded by the sample limits)."""
    from mwip.budget import estimate

    if campaign.kind == "robustness":
        n_ctrl, duration = len(campaign.controllers), float(campaign.duration)
        sensors, dt = str(campaign.sensors), 0.005
    elif campaign.kind == "bench":
        bench: Any = getattr(campaign, "bench", None)
        n_ctrl, duration = len(getattr(campaign, "entrants", ())), float(bench.duration)
        sensors, dt = "twin", 0.0005
    else:
        return None
    plant_s = float(campaign.samples) * n_ctrl * duration
    rate = PLANT_S_PER_S["twin" if sensors == "twin" else "ideal"]
    block = estimate(duration, 0.005, dt, n=int(campaign.block)).bytes
    return Work(plant_s, plant_s / rate / 3600.0, float(block))


def check_work(campaign: Campaign, workers: int, max_hours: float | None = None,
               local: bool = True) -> None:  # fmt: skip
    """Refuse a run whose estimated time exceeds ``max_hours`` hours of one core (default
    :data:`MAX_HOURS`), or (``local``: its workers on this machine) whose ``workers`` blocks
    in memory at once exceed half this machine's memory (one-line ``ValueError``: what it
    would need, what raises the limit)."""
    w = work(campaign)
    if w is None:
        return
    limit = MAX_HOURS if max_hours is None else float(max_hours)
    if not (math.isfinite(limit) and limit > 0):
        raise ValueError(f"--max-hours must be a positive number, got {max_hours!r}")
    if w.cpu_hours > limit:
        raise ValueError(f"the run would simulate {w.plant_s:.3g} robot-seconds, about "
                         f"{w.cpu_hours:.3g} hours of one core (~{w.cpu_hours / workers:.3g} h "
                         f"on {workers} workers), more than {limit:g} h: fewer samples, "
                         "controllers or seconds, or --max-hours to allow it")  # fmt: skip
    total = _memory() if local else 0.0
    if total and workers * w.block_bytes > 0.5 * total:
        raise ValueError(f"--jobs {workers}: {workers} blocks in memory at once need about "
                         f"{workers * w.block_bytes / 2**30:.3g} GiB, more than half of this "
                         f"machine's {total / 2**30:.3g} GiB: fewer jobs or a smaller "
                         "block")  # fmt: skip


def _memory() -> float:
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # not on this platform
        return 0.0


def max_jobs() -> int:
    """The most worker processes a local run starts: 4 per CPU."""
    return 4 * (os.cpu_count() or 1)


def _chunk_name(first: int, last: int) -> str:
    return f"blocks-{first:06d}-{last:06d}.parquet"


def done_blocks(out: Path) -> set[int]:
    """The blocks covered by the chunk files in ``out/chunks``."""
    done: set[int] = set()
    folder = out / "chunks"
    if folder.is_dir():
        for p in folder.iterdir():
            m = _CHUNK_RE.match(p.name)
            if m:
                done.update(range(int(m.group(1)), int(m.group(2)) + 1))
    return done


_CONTROLLERS: dict[str, Any] = {}


def compute_chunk(campaign: Campaign, blocks: list[int]) -> Any:
    """The rows of ``blocks`` (consecutive) as a pandas DataFrame (runs on a worker).

    Robustness: each controller is designed once per process (cached by campaign identity)
    and copied fresh for every block. Claims: :func:`mwip.campaign.claims.run_block`.
    """
    import pandas as pd

    own = getattr(campaign, "compute_chunk", None)
    if own is not None:  # work of another room (mwip.bench, mwip.calibration) brings its own
        # block runner
        return own(blocks)
    frames = []
    if campaign.kind == "claims":
        from mwip.campaign.claims import run_block as run_claims

        for b in blocks:
            frames.append(run_claims(campaign, b))
    else:
        from mwip.campaign.blocks import build_controllers, run_block

        key = campaign.identity()
        if key not in _CONTROLLERS:
            _CONTROLLERS.clear()
            _CONTROLLERS[key] = build_controllers(campaign)
        ctrls = _CONTROLLERS[key]
        for b in blocks:
            frames.extend(pd.DataFrame(cols) for cols in run_block(campaign, b, ctrls))
    return pd.concat(frames, ignore_index=True)


def _write_chunk(out: Path, blocks: list[int], df: Any) -> Path:
    path = out / "chunks" / _chunk_name(blocks[0], blocks[-1])
    return write_parquet_atomic(path, df)


def _order_key(campaign: Campaign) -> tuple[str, list[str]]:
    own = getattr(campaign, "order_key", None)
    if own is not None:
        return own()
    if campaign.kind == "claims":
        return "study", list(campaign.studies)
    return "controller", [c.label for c in campaign.controllers]


def assemble(campaign: Campaign, out: Path) -> Any:
    """``results.parquet`` from the chunk files: rows of samples < N, in (controller, sample)
    order (claims: (study, sample, claim) order); written atomically; returns the table."""
    import pandas as pd

    files = sorted(p for p in (out / "chunks").iterdir() if _CHUNK_RE.match(p.name))
    df = pd.concat([pd.read_parquet(p) for p in files], ignore_index=True)
    df = df[df["sample"] < campaign.samples]
    col, order = _order_key(campaign)
    rank = df[col].map({name: i for i, name in enumerate(order)})
    keys = ["_rank", "sample"] + (["claim_index"] if "claim_index" in df else [])
    df = df.assign(_rank=rank).sort_values(keys, kind="stable").drop(columns="_rank")
    df = df.reset_index(drop=True)
    write_parquet_atomic(out / "results.parquet", df)
    return df


def _record(campaign: Campaign) -> dict[str, Any]:
    return {"identity": campaign.identity(), "campaign": campaign.source}


def _check_out(campaign: Campaign, out: Path) -> None:
    import json

    rec = out / "campaign.json"
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out: {str(out)!r} exists and is not a folder")
    if rec.exists():
        try:
            old = json.loads(rec.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = {}
        if old.get("identity") != campaign.identity():
            raise ValueError(f"--out: {str(out)!r} holds a different campaign; use another folder")
    elif out.is_dir() and any(p.name != LOCK for p in out.iterdir()):  # (LOCK: ours, held)
        raise ValueError(f"--out: {str(out)!r} is not empty and holds no campaign")


def _finished(campaign: Campaign, out: Path) -> bool:
    import json

    rec = out / "campaign.json"
    if not (rec.exists() and (out / "results.parquet").exists()):
        return False
    data = json.loads(rec.read_text(encoding="utf-8"))
    return bool(data.get("finished_samples") == campaign.samples)


def _chunks(todo: list[int], size: int, first: int = 0) -> list[list[int]]:
    """Runs of consecutive blocks, at most ``size`` each; the ``first`` chunks of one block
    (each worker's first report comes after one block)."""
    out: list[list[int]] = []
    for b in todo:
        limit = 1 if len(out) <= first else size
        if out and b == out[-1][-1] + 1 and len(out[-1]) < limit:
            out[-1].append(b)
        else:
            out.append([b])
    return out


ProgressFn = Callable[[int, int, float], None]


def _default_progress(done: int, total: int, elapsed: float) -> None:
    """The progress line on stderr (redrawn in place on a terminal): samples done, time so
    far and the estimated time left (:class:`_Progress` estimates from this run's work)."""
    _Progress(0)(done, total, elapsed)


class _Progress:
    """:func:`_default_progress` for one run: its estimate of the time left counts only the
    samples run now (``start``: those done before, by an earlier run) and is printed once it
    can be (after the first chunk). On a terminal, :meth:`ticking` redraws the line every
    :data:`_TICK` s while no chunk finishes (a chunk can take longer than that: the line's
    clock and estimate still move)."""

    def __init__(self, start: int) -> None:
        self.start = start
        self.last: tuple[int, int, float] | None = None  # done, total, perf_counter() of t0
        self.lock = threading.Lock()

    def __call__(self, done: int, total: int, elapsed: float) -> None:
        with self.lock:
            self.last = (done, total, time.perf_counter() - elapsed)
            self._draw(done, total, elapsed)

    def _draw(self, done: int, total: int, elapsed: float) -> None:
        frac = done / total if total else 1.0
        now = done - self.start
        eta = elapsed * (total - done) / now if now > 0 else float("nan")
        width = 30
        bar = "#" * int(width * frac) + "-" * (width - int(width * frac))
        eta_text = "--" if not math.isfinite(eta) else _duration(eta)
        end = "\r" if sys.stderr.isatty() and done < total else "\n"
        sys.stderr.write(f"[{bar}] {done}/{total} samples  {_duration(elapsed)}  "
                         f"left about {eta_text}{end}")  # fmt: skip
        sys.stderr.flush()

    @contextlib.contextmanager
    def ticking(self) -> Iterator[None]:
        """Redraw the line every :data:`_TICK` s in a thread while the block runs (only on a
        terminal: a log file gets a line per chunk)."""
        if not sys.stderr.isatty():
            yield
            return
        stop = threading.Event()

        def tick() -> None:
            while not stop.wait(_TICK):
                with self.lock:
                    if self.last is not None and self.last[0] < self.last[1] and not stop.is_set():
                        done, total, t0 = self.last
                        self._draw(done, total, time.perf_counter() - t0)

        thread = threading.Thread(target=tick, name="mwip-progress", daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            with self.lock:  # a redraw in progress ends before the caller writes again
                pass


#: Seconds between redraws of the progress line on a terminal while no chunk finishes.
_TICK = 5.0


def _duration(seconds: float) -> str:
    """``42 s``, ``3.5 min``, ``2.1 h``."""
    if seconds < 100:
        return f"{seconds:.0f} s"
    if seconds < 6000:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def run_campaign(
    campaign: Campaign,
    out: Path,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    chunk: int | None = None,
    progress: ProgressFn | None = _default_progress,
    max_hours: float | None = None,
) -> RunSummary:
    """Run (or continue) ``campaign`` into ``out``; see the module docstring.

    ``chunk``: samples per chunk (rounded up to whole blocks; default: one block per chunk,
    at most :data:`_MAX_CHUNKS` chunks, each worker's first chunk one block). ``jobs``:
    worker processes (default: the machine's CPUs). ``max_hours``: the most hours of one core
    the run may be estimated to take (:func:`check_work`; default :data:`MAX_HOURS`).
    Ctrl-C (``KeyboardInterrupt``) stops after saving nothing partial and returns
    ``status="interrupted"``; the next run continues.
    """
    t0 = time.perf_counter()
    if jobs is not None and not 1 <= jobs <= max_jobs():
        raise ValueError(f"--jobs must be an integer in [1, {max_jobs()}] (4 per CPU), "
                         f"got {jobs!r}")  # fmt: skip
    if chunk is not None and chunk < 1:
        raise ValueError(f"--chunk must be an integer >= 1, got {chunk!r}")
    if scheduler is not None and not (isinstance(scheduler, str) and scheduler.strip()):
        raise ValueError("--scheduler: the address is empty; give tcp://HOST:PORT (or leave "
                         "--scheduler out: a local cluster)")  # fmt: skip
    out = Path(out)
    _check_out(campaign, out)
    total = n_blocks(campaign)
    if _finished(campaign, out):
        import pandas as pd

        rows = len(pd.read_parquet(out / "results.parquet", columns=["sample"]))
        return RunSummary("finished-before", 0, total, rows, out / "results.parquet", 0.0)
    done = done_blocks(out)
    todo = [b for b in range(total) if b not in done]
    workers = jobs if jobs is not None else (os.cpu_count() or 1)
    per = (
        math.ceil(chunk / campaign.block)
        if chunk is not None
        else max(1, math.ceil(len(todo) / _MAX_CHUNKS))
    )
    chunks = _chunks(todo, per, first=0 if chunk is not None else workers)
    if chunks:
        check_work(campaign, workers, max_hours, local=scheduler is None)
    units = n_units(campaign)

    def size(b: int) -> int:  # units asked in block b (the last block is run whole, and the
        # rows beyond what was asked are dropped: a block's noise depends on its size)
        return max(0, min((b + 1) * campaign.block, units) - b * campaign.block)

    samples_total = sum(size(b) for b in range(total))
    samples_done = [sum(size(b) for b in done & set(range(total)))]
    if progress is _default_progress:
        progress = _Progress(samples_done[0])
    dask = (_connect(workers, scheduler) if chunks and (scheduler is not None or workers > 1)
            else None)  # fmt: skip
    if isinstance(progress, _Progress) and chunks:  # at once: what there is to do (a given
        # progress function is called after each chunk only, as before), once the cluster is
        # up (a scheduler refused or Ctrl-C while it starts stays one line)
        progress(samples_done[0], samples_total, time.perf_counter() - t0)
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "campaign.json", _record(campaign))

    def finished(blocks: list[int], df: Any) -> None:
        _write_chunk(out, blocks, df)
        samples_done[0] += sum(size(b) for b in blocks)
        if progress is not None:
            progress(samples_done[0], samples_total, time.perf_counter() - t0)

    interrupted = False
    ticking = progress.ticking() if isinstance(progress, _Progress) else contextlib.nullcontext()
    try:
        with ticking:
            if dask is not None:
                with deaf_spawns():  # (a worker the nanny restarts is deaf to Ctrl-C too)
                    _run_dask(campaign, chunks, *dask, finished)
            else:
                for blocks in chunks:
                    finished(blocks, compute_chunk(campaign, blocks))
    except KeyboardInterrupt:
        interrupted = True
    ran = len(done_blocks(out) - done)
    if interrupted:
        return RunSummary("interrupted", ran, total, 0, out, time.perf_counter() - t0)
    df = assemble(campaign, out)
    rec = _record(campaign)
    rec["finished_samples"] = campaign.samples
    write_json_atomic(out / "campaign.json", rec)
    return RunSummary(
        "done", ran, total, len(df), out / "results.parquet", time.perf_counter() - t0
    )


#: Seconds a Dask scheduler has to accept the connection and send its handshake.
SCHEDULER_TIMEOUT_S = 10.0
#: The largest first message a scheduler's handshake plausibly is (bytes).
_HANDSHAKE_MAX = 1 << 20


def check_scheduler(address: str, timeout: float = SCHEDULER_TIMEOUT_S) -> None:
    """Check that a Dask scheduler answers at ``address`` (``tcp://HOST:PORT`` or
    ``HOST:PORT``) before a client connects: the TCP connection and the scheduler's
    handshake (the first message a Dask server sends on every connection: its Python and
    pickle versions) must come within ``timeout`` s, and be a Dask message. One-line
    ``ValueError`` naming ``--scheduler`` otherwise (unreachable, no answer, not a Dask
    scheduler). Other transports (``tls://``, ``ucx://``, ...) are left to the client's own
    timeout."""
    import socket
    import struct

    if not isinstance(address, str) or not address.strip():
        raise ValueError("--scheduler: the address is empty; give tcp://HOST:PORT (or leave "
                         "--scheduler out: a local cluster)")  # fmt: skip
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.protocol import loads
        from distributed.protocol.utils import unpack_frames
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ValueError("campaigns on Dask need the extra: pip install 'mwip[campaign]'") from exc
    try:
        scheme, loc = parse_address(address.strip())
        from distributed.comm.registry import backends

        if scheme not in backends:
            raise ValueError(f"unknown scheme {scheme!r}; known: {', '.join(sorted(backends))}")
        if scheme != "tcp":
            return
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"--scheduler: {address!r} is not an address tcp://HOST:PORT "
                         f"({exc})") from None  # fmt: skip
    deadline = time.monotonic() + timeout
    where = f"--scheduler: {address!r}"
    try:
        sock = socket.create_connection((host, int(port)), timeout=timeout)
    except TimeoutError:
        raise ValueError(f"{where} accepted no connection within {timeout:g} s") from None
    except OSError as exc:
        raise ValueError(f"{where}: cannot reach it ({exc.strerror or exc})") from None

    def recv(n: int) -> bytes:
        data = b""
        while len(data) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError
            sock.settimeout(left)
            chunk = sock.recv(min(n - len(data), 1 << 16))
            if not chunk:
                raise ConnectionError("closed the connection")
            data += chunk
        return data

    not_dask = f"{where} is not a Dask scheduler"
    try:
        head = recv(8)
        (size,) = struct.unpack("<Q", head)
        if not 0 < size <= _HANDSHAKE_MAX:
            raise ValueError(f"{not_dask} (it answered {head!r}...)")
        body = recv(size)
        try:
            msg = loads(unpack_frames(body), deserialize=False)
        except Exception:  # noqa: BLE001 - any garbage
            raise ValueError(f"{not_dask} (its answer is not a Dask message)") from None
        if not (isinstance(msg, dict) and "pickle-protocol" in msg):
            raise ValueError(f"{not_dask} (its first message is not a Dask handshake)")
    except TimeoutError:
        raise ValueError(f"{where} gave no Dask handshake within {timeout:g} s (not a Dask "
                         "scheduler, or too busy)") from None  # fmt: skip
    except (ConnectionError, OSError) as exc:
        raise ValueError(f"{not_dask} (it {exc})") from None
    finally:
        sock.close()


def _connect(workers: int, scheduler: str | None) -> tuple[Any, Any]:
    """A Dask client: on the cluster at ``scheduler`` (checked first,
    :func:`check_scheduler`), or on a new LocalCluster of ``workers`` processes (one thread
    each). Returns ``(client, cluster or None)``."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ValueError("campaigns on Dask need the extra: pip install 'mwip[campaign]'") from exc
    import logging

    logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler is not None:
        check_scheduler(scheduler, timeout=SCHEDULER_TIMEOUT_S)
        try:
            return Client(scheduler, timeout=SCHEDULER_TIMEOUT_S), None
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"--scheduler: cannot reach {scheduler!r}: {exc}") from None
    cluster = _quiet_workers(
        lambda: LocalCluster(  # (its HTTP server on a free port: port 8787 may be another
            # run's, and Dask would warn of it)
            n_workers=workers, threads_per_worker=1, processes=True,
            dashboard_address="127.0.0.1:0",
        )
    )
    return Client(cluster), cluster


@contextlib.contextmanager
def deaf_spawns() -> Iterator[None]:
    """Processes that :mod:`multiprocessing` spawns meanwhile (from any thread: Dask starts
    its workers from its event loop's thread) start with SIGINT blocked, so the terminal's
    Ctrl-C never reaches them; this process's own handling of SIGINT is untouched (its mask
    is changed only in the spawning thread, around the spawn: a Ctrl-C then waits there for
    microseconds and is delivered, never lost)."""
    import signal
    from multiprocessing import util

    real = util.spawnv_passfds

    def spawn(path: Any, args: Any, passfds: Any) -> int:
        if any("resource_tracker" in str(a) for a in args):  # after a Ctrl-C (its workers
            # killed) it would warn of their semaphores in lines of its own; it removes them
            args = [args[0], "-W", "ignore::UserWarning", *args[1:]]
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            return real(path, args, passfds)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)

    util.spawnv_passfds = spawn
    try:
        yield
    finally:
        util.spawnv_passfds = real


def kill_children() -> None:
    """Kill this process's worker processes at once (SIGKILL), Dask's log silenced: after
    Ctrl-C nothing of theirs is worth a graceful stop (their chunks are lost either way).
    Every child process is killed, also one spawned a moment ago and not yet handed its
    work (it would print an ``EOFError`` when this process ends), but multiprocessing's
    resource tracker, which removes the workers' semaphores once this process is gone."""
    import logging
    import multiprocessing

    for name in ("distributed", "asyncio", "tornado"):  # the loop's threads see them die
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    kids: list[Any] = []
    try:
        import psutil  # (a dependency of Dask's distributed)

        kids = [k for k in psutil.Process().children(recursive=True)
                if not any("resource_tracker" in a for a in _cmdline(k))]  # fmt: skip
    except Exception:  # noqa: BLE001 - psutil missing or a process gone meanwhile
        kids = list(multiprocessing.active_children())
    for k in kids:
        try:
            k.kill()  # (reaped by Dask's threads or at exit: not waited for here)
        except Exception:  # noqa: BLE001 - gone already
            pass


def _cmdline(proc: Any) -> list[str]:
    try:
        return list(proc.cmdline())
    except Exception:  # noqa: BLE001 - gone, or not ours to read
        return []


def _quiet_workers(start: Callable[[], Any]) -> Any:
    """``start()`` with the worker processes it spawns deaf to Ctrl-C (:func:`deaf_spawns`:
    SIGINT blocked in them) and Dask's log at ``error`` (inherited): Ctrl-C (sent to the
    whole terminal process group) reaches only this process, which stops them
    (:func:`_run_dask`'s ``finally``), instead of each worker printing a ``KeyboardInterrupt``
    traceback and warnings about its cancelled task. A Ctrl-C while the cluster starts is
    never dropped: it interrupts the start, whose processes are killed."""
    env_key = "DASK_LOGGING__DISTRIBUTED"
    env_old = os.environ.get(env_key)
    os.environ[env_key] = "error"
    try:
        with deaf_spawns():
            return start()
    except KeyboardInterrupt:
        kill_children()
        raise
    finally:
        if env_old is None:
            os.environ.pop(env_key, None)
        else:
            os.environ[env_key] = env_old


def _run_dask(
    campaign: Campaign,
    chunks: list[list[int]],
    client: Any,
    cluster: Any,
    finished: Callable[[list[int], Any], None],
) -> None:
    """Submit every chunk to Dask and save each as it completes (in any order); then close
    the client (and the local cluster)."""
    from dask.distributed import as_completed

    futures: list[Any] = []
    interrupted = False
    try:
        # the campaign travels inside each task (a few kB), not as scattered data: a scattered
        # value is a dependency with a content-hashed key, and the next run on the same
        # scheduler scatters the same key while the previous client's release of it is still
        # in flight (or a worker holding it is removed under load): its tasks then fail with
        # "lost dependencies". A task without dependencies is simply rerun elsewhere.
        where = {}
        for blocks in chunks:
            key = f"mwip-campaign-{blocks[0]}-{uuid.uuid4().hex}"
            fut = client.submit(compute_chunk, campaign, blocks, pure=False, key=key)
            where[fut.key] = blocks
            futures.append(fut)
        for fut in as_completed(futures):
            finished(where[fut.key], fut.result())
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        if interrupted and cluster is not None:  # Ctrl-C: stop now, not in order
            kill_children()
            _close_quietly(client, cluster)
        else:
            for fut in futures:
                fut.cancel()
            client.close()
            if cluster is not None:
                cluster.close()


def _close_quietly(client: Any, cluster: Any, wait: float = 0.3) -> None:
    """Close a client and a cluster whose workers are gone, in the background: waited for at
    most ``wait`` s (the command ends at once after Ctrl-C)."""
    import contextlib
    import threading

    def close() -> None:
        with contextlib.suppress(Exception):
            client.close(timeout=1)
        with contextlib.suppress(Exception):
            cluster.close(timeout=1)

    t = threading.Thread(target=close, name="mwip-dask-close", daemon=True)
    t.start()
    t.join(wait)
