"""Running several studies: in parallel processes, into a staging folder, with a run record.

:func:`run_studies` is what ``mwip run`` and ``mwip reproduce`` call. The studies write into
a staging folder beside ``out`` (:class:`mwip.report.Staging`); when all are done the
successful ones replace their old folders in ``out``, the run record ``out/run.json`` is
updated and the report ``out/index.html`` rebuilt. A study that raises is recorded with its
error and does not stop the others (its earlier results in ``out``, if any, are kept);
Ctrl-C discards the staging folder and leaves ``out`` as it was.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import platform
import queue as queue_module
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from datetime import UTC, datetime
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import scipy

from mwip.hardware.identified import default_twin
from mwip.hardware.twin import Twin
from mwip.io import write_json_atomic, write_text_atomic
from mwip.outdir import MARKER, marker_text, owner
from mwip.params import Params
from mwip.report.html import write_report
from mwip.report.posters import draw_poster
from mwip.report.results import RUN_RECORD, load_run_record
from mwip.report.staging import Staging, signals_held
from mwip.sim.engine import RUN_END_HOOKS
from mwip.studies import registry, settings

__all__ = ["StudyOutcome", "expected_runs", "run_studies"]

#: (name, metrics document or None, error or None, wall time in s)
StudyOutcome = tuple[str, dict[str, Any] | None, str | None, float]


def _run_one(
    name: str,
    out: Path,
    quick: bool,
    plant: Params,
    nominal: Params,
    overrides: dict[str, Any] | None = None,
    twin: Twin | None = None,
) -> StudyOutcome:
    """Run one study (in a worker process or here), catching its failure."""
    _current_study[0] = name
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            doc = registry.run_study(name, out, quick=quick, plant=plant, nominal=nominal,
                                     overrides=overrides, twin=twin)  # fmt: skip
            draw_poster(out / name)  # the report's picture of its main run, drawn in parallel
    except Exception as exc:  # noqa: BLE001 - recorded and reported; exit code says so
        return name, None, f"{type(exc).__name__}: {exc}", time.perf_counter() - t0
    return name, doc, None, time.perf_counter() - t0


_current_study: list[str] = [""]


def _init_worker(q: Any) -> None:
    """Worker start-up: report each finished simulation run of the current study on ``q``.

    Workers ignore SIGINT: Ctrl-C reaches the whole process group, and the parent, not each
    worker, decides what happens (it stops them, :func:`_stop_pool`).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    RUN_END_HOOKS.append(lambda _res: q.put(_current_study[0]))
    threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()


def _exit_with_parent(parent: int) -> None:
    """A worker whose parent is gone (killed outright, SIGKILL or SIGTERM) stops too,
    instead of finishing its study for nobody."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)


def _openmp_started() -> bool:
    """Whether this process has started Numba's worker threads on the OpenMP layer: a child
    forked from it aborts when it runs a threaded loop ("fork() called from a process already
    using GNU OpenMP"), so its studies run in this process instead (the workers are forked,
    and a fork server or spawned workers would re-run a user's script without a main guard)."""
    import sys

    parallel = sys.modules.get("numba.np.ufunc.parallel")
    if parallel is None or not getattr(parallel, "_is_initialized", False):
        return False
    try:
        return bool(parallel.threading_layer() == "omp")
    except ValueError:  # (no layer launched)
        return False


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` at once: kill its workers (their studies are abandoned), then reap them,
    so that nothing is left for the interpreter to join at exit."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(timeout=1.0)


def _counting_hook(name: str, on_run: Callable[[str], None] | None) -> Any:
    if on_run is None:
        return None

    def hook(_res: Any) -> None:
        on_run(name)

    RUN_END_HOOKS.append(hook)
    return hook


def _drain(q: Any, on_run: Callable[[str], None] | None) -> None:
    while True:
        try:
            study = q.get_nowait()
        except queue_module.Empty:
            return
        if on_run is not None:
            on_run(study)


def _counts_file() -> Path:
    """Where the studies' run counts are kept (:func:`expected_runs`)."""
    from mwip.cache import cache_dir

    return cache_dir() / "study-runs.json"


def expected_runs(names: list[str], quick: bool) -> dict[str, int | None]:
    """How many simulation runs each study of ``names`` made the last time it ran on this
    machine in this mode (``quick`` or not): the total of its progress display. ``None``
    where it has not run yet (the count is kept in :func:`mwip.cache.cache_dir`, derived data
    like the rest of that folder; a study's run count does not depend on the robot)."""
    import json

    try:
        known = json.loads(_counts_file().read_text())
    except (OSError, ValueError):
        known = {}
    out: dict[str, int | None] = {}
    for name in names:
        n = known.get(f"{name}|{'quick' if quick else 'full'}") if isinstance(known, dict) else None
        out[name] = n if isinstance(n, int) and n > 0 else None
    return out


def _remember_runs(counts: dict[str, int], quick: bool) -> None:
    """Keep ``counts`` (study -> runs made) for :func:`expected_runs`; never fails a run."""
    import json

    path = _counts_file()
    try:
        known = json.loads(path.read_text()) if path.is_file() else {}
        known = known if isinstance(known, dict) else {}
        mode = "quick" if quick else "full"
        known.update({f"{n}|{mode}": c for n, c in counts.items() if c > 0})
        path.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(path, dict(sorted(known.items())))
    except (OSError, ValueError):
        pass


def _environment() -> dict[str, Any]:
    return {
        "mwip_version": version("mwip"),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "platform": platform.platform(),
        "command": " ".join(["mwip", *sys.argv[1:]]),
    }


def run_studies(
    names: list[str],
    out: Path,
    *,
    quick: bool = False,
    jobs: int = 1,
    plant: Params | None = None,
    nominal: Params | None = None,
    overrides: dict[str, dict[str, Any]] | None = None,
    on_done: Callable[[StudyOutcome], None] | None = None,
    on_run: Callable[[str], None] | None = None,
    damping: str = "units",
    twin: Twin | None = None,
    command: str | None = None,
    robot: dict[str, str] | None = None,
) -> dict[str, Any]:
    """Run ``names`` into ``out``; returns the run record (also written to ``out/run.json``).

    ``jobs`` processes (1: in this process). ``plant``/``nominal`` replace the book's robot
    and design model (default Tables 3.1, 3.2); ``overrides[name]`` replaces some of study
    ``name``'s settings (:mod:`mwip.studies.settings`). ``damping`` names the reading of
    the book's tables the robot was built with (recorded in ``run.json``). ``twin``: the
    Chapter 6 studies' twin (default: the default robot's; recorded in ``run.json``
    as a robot file). ``on_done`` is called as each study ends, ``on_run(study)`` as each of
    its simulation runs ends (for a progress display; :func:`expected_runs` gives the totals).
    Each study's number of runs is recorded in ``run.json`` (``runs``), and ``robot[name]``,
    when given, says what study ``name`` ran on other than the book's robot (e.g.
    ``"--params my_robot.toml"``; the report's section title shows it). ``command`` names the
    command that owns ``out`` in its marker (:mod:`mwip.outdir`; a folder already owned keeps
    its owner).
    """
    order = registry.names()
    for name in names:
        registry.get(name)  # ValueError naming the studies if unknown
    overrides = {n: settings.validate(n, o) for n, o in (overrides or {}).items()}
    plant, nominal = registry.robot(plant, nominal)
    twin = twin if twin is not None else default_twin()
    started = datetime.now(UTC).isoformat(timespec="seconds")
    t0 = time.perf_counter()
    outcomes: dict[str, StudyOutcome] = {}
    counts = dict.fromkeys(names, 0)

    def one_run(study: str) -> None:
        counts[study] = counts.get(study, 0) + 1
        if on_run is not None:
            on_run(study)

    def done(outcome: StudyOutcome) -> None:
        outcomes[outcome[0]] = outcome
        if on_done is not None:
            on_done(outcome)

    if jobs > 1 and len(names) > 1 and _openmp_started():
        from mwip.notice import once

        once("fork-openmp", "running the studies one after another in this process: it has "
             "already run Numba's OpenMP threads (a threaded batch), which a forked worker "
             "cannot use (GNU OpenMP aborts it)")  # fmt: skip
        jobs = 1
    with Staging(out) as stage:
        assert stage.path is not None
        if jobs <= 1 or len(names) == 1:
            for name in names:
                hook = _counting_hook(name, one_run)
                try:
                    done(_run_one(name, stage.path, quick, plant, nominal, overrides.get(name),
                                  twin))  # fmt: skip
                finally:
                    if hook is not None:
                        RUN_END_HOOKS.remove(hook)
        else:
            queue: Any = multiprocessing.get_context().Queue()
            pool = ProcessPoolExecutor(
                max_workers=min(jobs, len(names)), initializer=_init_worker, initargs=(queue,)
            )
            try:
                pending = {
                    pool.submit(
                        _run_one, n, stage.path, quick, plant, nominal, overrides.get(n), twin
                    )  # fmt: skip
                    for n in _longest_first(names)
                }
                while pending:
                    finished, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                    _drain(queue, one_run)
                    for fut in finished:
                        done(fut.result())
                _drain(queue, one_run)
            except BaseException:
                _stop_pool(pool)
                raise
            pool.shutdown()
        with stage.lock():  # OUT's record and report are read and replaced as one
            record = load_run_record(out) if set(order) - set(names) else {}
            studies = dict(record.get("studies", {}))
            for name in names:
                _, doc, error, wall = outcomes[name]
                studies[name] = {"wall_s": round(wall, 3), "error": error, "runs": counts[name],
                                 "settings": settings_of(name, overrides.get(name))}  # fmt: skip
                if (robot or {}).get(name):
                    studies[name]["robot"] = robot[name]  # type: ignore[index]
            record.update(_environment())
            record.update({
                "started": started, "wall_s": round(time.perf_counter() - t0, 3), "jobs": jobs,
                "quick": quick, "studies": {n: studies[n] for n in order if n in studies},
                "params": {"plant": plant.to_dict(), "nominal (design)": nominal.to_dict()},
                "damping": damping, "robot": _robot_text(plant, nominal, twin),
                "twin_status": twin_status(twin),
            })  # fmt: skip
            write_json_atomic(stage.path / RUN_RECORD, record)
            _remember_runs({n: counts[n] for n in names if outcomes[n][1] is not None}, quick)
            write_text_atomic(stage.path / MARKER, marker_text(owner(out) or command))
            ok = [n for n in names if outcomes[n][1] is not None]
            _stage_report(stage.path, out, ok)
            # the old report goes first, the new one last, after the run record it was made
            # from: at any moment OUT's index.html is absent or matches OUT's run.json (and
            # Ctrl-C is held back until the commit is done)
            with signals_held():
                stage.commit([*ok, MARKER, RUN_RECORD, REPORT], retire=(REPORT,))
    return record


REPORT = "index.html"


def _stage_report(stage: Path, out: Path, ok: list[str]) -> None:
    """Write the report of OUT as it will be after the commit into the staging folder: the
    studies of ``ok`` from the staging folder, everything else the report reads from OUT
    (other studies, ``compare-*``, a claims campaign) linked in while it is rendered."""
    import shutil

    for name in registry.names():
        if name not in ok:
            shutil.rmtree(stage / name, ignore_errors=True)  # a failed study's partial output
    links = []
    try:
        entries = sorted(out.iterdir()) if out.is_dir() else []
        for old in entries:
            dst = stage / old.name
            if old.name.startswith(".") or old.name in ok or dst.exists() or dst.is_symlink():
                continue
            if old.is_dir() and not old.is_symlink():
                dst.symlink_to(old.resolve(), target_is_directory=True)
                links.append(dst)
        write_report(stage)
    finally:
        for link in links:
            link.unlink(missing_ok=True)


def _longest_first(names: list[str]) -> list[str]:
    """The studies by decreasing cost (``Study.cost``), so that the processes finish together."""
    return sorted(names, key=lambda n: -registry.get(n).cost)


def settings_of(name: str, overrides: dict[str, Any] | None) -> dict[str, Any]:
    """The settings study ``name`` ran with (defaults and overrides; {} if it has no file)."""
    try:
        return {**settings.defaults(name), **(overrides or {})}
    except ValueError:
        return dict(overrides or {})


def _robot_text(plant: Params, nominal: Params, twin: Any) -> str:
    """The robot file of the run: its body, design model and twin (default: the default
    twin)."""
    from mwip.robot import Robot, robot_to_toml

    tw = default_twin() if twin is None else twin
    try:
        return robot_to_toml(Robot(body=plant, design=nominal, twin=tw, name="run"))
    except ValueError:  # a batch of robots: no one file
        return ""


def twin_status(twin: Any) -> dict[str, Any]:
    """:func:`mwip.hardware.identified.status` of the studies' twin."""
    from mwip.hardware.identified import status

    return status(twin)
