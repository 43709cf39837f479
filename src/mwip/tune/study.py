"""The Optuna study of a tuning run: storage, samplers, pruning, resuming.

Storage. Any Optuna RDB URL (``sqlite:///DIR/study.db`` by default); several processes may
work on one study through a shared database (each with its own ``--out``). Every state change
of a trial is one database transaction, so ``kill -9`` at any moment leaves the finished trials
as they were and at most the trials in flight ``RUNNING``. Opening a storage is bounded:
connecting and the database's handshake must finish within :data:`CONNECT_TIMEOUT_S`, else
the URL is refused (``--storage``, exit 2); an in-memory SQLite database (``sqlite://``,
``sqlite:///:memory:``) is refused (it could be neither shared nor resumed).

Slots. A trial's place in the run is its *slot*, ``0, 1, 2, ...`` (the ``number`` of
``trials.csv``): the smallest slot that no finished, running or waiting trial holds. A trial
that was interrupted (``kill -9``, Ctrl-C, a crash: left ``RUNNING`` by a process that no
longer runs, or failed without an error of its own) frees its slot, and the next trial takes
it again. The sampler is rebuilt for every trial and seeded from ``(seed, slot)``, and every
sampler here (TPE, CMA-ES, NSGA-II) draws from the finished trials only, so the trial that
takes a freed slot draws exactly the parameters of the interrupted one (all of them): a
sequential run killed at any moment and run again gives the same trials, in the same slots,
as the uninterrupted run. A trial whose objective raised an error is retried once (the same
slot, so the same parameters); a slot that failed twice is given up. Processes sharing a study
take different slots (the rare trial that took a slot another one holds is failed as a
``duplicate``); their trials depend on the order in which the others finish.

Resuming. Before every trial, trials left ``RUNNING`` by a process that no longer runs are
marked failed: with the default storage every ``RUNNING`` (or ``WAITING``) trial found at start
(the output folder is held by one process, :func:`mwip.outdir.hold`); with a shared one those
of a dead process on this machine (each trial records ``host:pid``) and, through Optuna's
heartbeat, those of any machine that has not been heard from for :data:`GRACE_S`. The run
stops when the study holds ``trials`` finished (complete or pruned) slots: the same command
continues a killed run; a finished study runs nothing more. Slot 0 is the book's settings, so
the best trial is never worse than the book on the tuning robots.

Pruning (one objective). A trial reports, after each chunk of robots, a lower bound of its
final cost: ``f / N`` with ``f`` its failures so far (the cost is ``(f + g) / N``, ``g`` in
``[0, 1)``, :mod:`mwip.tune.objective`); it is pruned as soon as that bound exceeds the best
finished cost, i.e. once it has failed on more robots than the best trial. A pruned trial
could never have become the best, so pruning changes no result, only the time.
"""

from __future__ import annotations

import copy
import errno
import math
import os
import socket
import threading
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mwip.tune.space import Space

__all__ = ["require_optuna", "open_storage", "close_storage", "open_study", "make_sampler",
           "optimise", "Outcome", "recover", "finished", "finished_trials", "slot_of",
           "next_slot", "storage_errors", "SAMPLERS", "GRACE_S", "CONNECT_TIMEOUT_S"]  # fmt: skip

SAMPLERS: tuple[str, ...] = ("tpe", "cmaes", "nsga2")
#: Heartbeat of a running trial (s) and the silence after which another process may fail it.
HEARTBEAT_S = 30
GRACE_S = 120
#: Seconds a storage has to accept the connection and answer the database's handshake.
CONNECT_TIMEOUT_S = 10.0


def require_optuna() -> Any:
    """The optuna module, or a one-line ``ValueError`` saying how to install it. Optuna's
    and SQLAlchemy's own log lines are silenced: every failure reaches the caller as an
    exception (and the command line says it in one line)."""
    try:
        import optuna
    except ImportError:
        raise ValueError("mwip tune needs Optuna and cmaes: pip install 'mwip[tune]'") from None
    import logging

    optuna.logging.set_verbosity(optuna.logging.CRITICAL)
    for name in ("sqlalchemy", "sqlalchemy.pool", "sqlalchemy.engine"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    return optuna


def _in_memory(url: str) -> bool:
    """Whether ``url`` is an SQLite database in memory (no file)."""
    from sqlalchemy.engine import make_url

    try:
        u = make_url(url)
    except Exception:  # noqa: BLE001 - refused later with the driver's own message
        return False
    if not u.get_backend_name().startswith("sqlite"):
        return False
    db = (u.database or "").strip()
    return db in ("", ":memory:") or db.startswith("file::memory:") or "mode=memory" in url


def _connect_args(url: str) -> dict[str, Any]:
    """The driver's own connect timeout where its dialect has one (seconds)."""
    from sqlalchemy.engine import make_url

    try:
        backend = make_url(url).get_backend_name()
    except Exception:  # noqa: BLE001
        return {}
    t = int(math.ceil(CONNECT_TIMEOUT_S))
    if backend.startswith("postgres"):
        return {"connect_timeout": t}
    if backend.startswith(("mysql", "mariadb")):
        return {"connect_timeout": t, "read_timeout": 60, "write_timeout": 60}
    if backend.startswith("sqlite"):
        return {"timeout": 60.0}  # waiting for another process's write lock
    return {}


def _bounded(fn: Callable[[], Any], seconds: float) -> Any:
    """``fn()`` in a helper thread, waited for at most ``seconds``; ``TimeoutError`` after
    that (the thread, stuck in a socket read, is left behind as a daemon)."""
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            box["error"] = exc

    t = threading.Thread(target=run, name="mwip-storage-open", daemon=True)
    t.start()
    t.join(seconds)
    if t.is_alive():
        raise TimeoutError(f"no answer within {seconds:g} s")
    if "error" in box:
        raise box["error"]
    return box["value"]


def open_storage(url: str, heartbeat: bool = True, timeout: float | None = None) -> Any:
    """An Optuna RDB storage at ``url``; ``ValueError`` naming ``--storage`` if it cannot be
    opened (bad URL, missing driver, an in-memory database, unreachable server, a service
    that is not a database or does not answer within ``timeout`` s (default
    :data:`CONNECT_TIMEOUT_S`), unwritable file)."""
    optuna = require_optuna()
    if not isinstance(url, str) or not url.strip():
        raise ValueError(f"--storage: give a database URL (sqlite:///FILE, postgresql://...), "
                         f"got {url!r}")  # fmt: skip
    if _in_memory(url):
        raise ValueError(f"--storage: {url!r} is an SQLite database in memory, which no other "
                         "process sees and which is gone when the run ends; give "
                         "sqlite:///FILE (or leave --storage out: OUT/study.db)")  # fmt: skip
    limit = CONNECT_TIMEOUT_S if timeout is None else float(timeout)
    kw: dict[str, Any] = {"engine_kwargs": {"connect_args": _connect_args(url)}}
    if heartbeat:
        kw.update(heartbeat_interval=HEARTBEAT_S, grace_period=GRACE_S)

    def make() -> Any:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return optuna.storages.RDBStorage(url, **kw)

    try:
        storage = _bounded(make, limit)
    except TimeoutError:
        raise ValueError(f"--storage: {url!r} accepted no connection or gave no database "
                         f"handshake within {limit:g} s (not a database, or unreachable)"
                         ) from None  # fmt: skip
    except Exception as exc:  # noqa: BLE001 - SQLAlchemy/driver errors of every kind
        mapped = as_os_error(exc, _where(url))
        if isinstance(mapped, OSError):  # the file system's failure, not the URL's
            raise mapped from None
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        hint = ""
        low = first.lower()
        if any(w in low for w in ("file is not a database", "not a database", "protocol",
                                  "unexpected", "invalid response", "lost connection",
                                  "closed the connection", "malformed")):  # fmt: skip
            hint = " (not a database?)"
        raise ValueError(f"--storage: cannot open {url!r}: {first[:200]}{hint}") from None
    if url.startswith("sqlite"):
        _sqlite_wal(storage.engine)
    return storage


def _where(url: str) -> str:
    """The file of an SQLite URL, else the URL (for messages)."""
    prefix = "sqlite:///"
    return url[len(prefix):] if url.startswith(prefix) else url


def close_storage(storage: Any) -> None:
    """Close every pooled connection of ``storage`` (SQLite then folds its write-ahead log
    into the file and removes ``-wal`` and ``-shm``); never raises."""
    engine = getattr(storage, "engine", None)
    if engine is None:
        return
    import gc

    try:
        with warnings.catch_warnings():  # SQLAlchemy's word on a connection it did not get back
            warnings.simplefilter("ignore")
            gc.collect()  # connections an interruption left unreferenced go back to the pool
        engine.dispose()
    except Exception:  # noqa: BLE001 - closing after a failure: nothing more to do
        pass


def storage_errors() -> tuple[type[BaseException], ...]:
    """The exception types a database raises while it is used (SQLAlchemy's, and Optuna's
    wrapper of them)."""
    from optuna.exceptions import StorageInternalError
    from sqlalchemy.exc import SQLAlchemyError

    return (SQLAlchemyError, StorageInternalError)


def as_os_error(exc: BaseException, where: str) -> BaseException:
    """A database error as the error the command line shows in one line: the file system's
    failures (a full disk, a file over the size limit, an I/O error, a read-only file) as an
    ``OSError`` naming ``where``; another as a ``RuntimeError`` with the database's first
    line."""
    causes: list[BaseException] = []
    e: BaseException | None = exc
    while e is not None and len(causes) < 5:  # Optuna's wrapper, SQLAlchemy's, the driver's
        causes.append(e)
        e = getattr(e, "orig", None) or e.__cause__ or e.__context__
    text = str(causes[-1]) if len(causes) > 1 else str(exc)
    low = " ".join(str(c) for c in causes).lower()
    if "disk is full" in low or "no space" in low or "database or disk is full" in low:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), where)
    if "disk i/o error" in low:
        return OSError(errno.EIO, os.strerror(errno.EIO), where)
    if "file too large" in low:
        return OSError(errno.EFBIG, os.strerror(errno.EFBIG), where)
    if "readonly" in low or "read-only" in low:
        return OSError(errno.EROFS, os.strerror(errno.EROFS), where)
    first = (text.strip().splitlines() or [type(exc).__name__])[0]
    return RuntimeError(f"the study's database failed: {first[:200]}")


def _sqlite_wal(engine: Any) -> None:
    """SQLite in write-ahead-log mode with ``synchronous = NORMAL``: a commit is a write to
    the log, not an ``fsync`` (Optuna commits every suggestion and attribute: ~30 per trial,
    ~10 ms each with ``fsync``). A committed transaction survives the death of the process
    (``kill -9``: the data is in the operating system's hands); only a power loss may lose
    the last ones, never corrupt the file. :func:`close_storage` folds the log back."""
    from sqlalchemy import event

    def on_connect(dbapi_conn: Any, record: Any) -> None:
        cur = dbapi_conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute("PRAGMA synchronous=NORMAL")
        cur.close()

    event.listen(engine, "connect", on_connect)
    engine.dispose()  # the connections opened so far: reopened with the pragmas


@dataclass(frozen=True)
class Outcome:
    """A trial's result: ``values`` (one per objective) and ``attrs`` recorded with it."""

    values: tuple[float, ...]
    attrs: Mapping[str, Any] = field(default_factory=dict)


def _trial_seed(seed: int, slot: int) -> int:
    ss = np.random.SeedSequence(int(seed), spawn_key=(int(slot),))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def make_sampler(kind: str, seed: int, space: Space, n_objectives: int = 1,
                 population: int | None = None) -> Any:  # fmt: skip
    """A sampler of ``kind`` (:data:`SAMPLERS`) reseeded for every trial from ``(seed,
    slot)`` (module docstring; :func:`optimise` sets ``sampler.slot`` before each trial).

    CMA-ES starts at the book's point (``x0`` = the defaults) with Optuna's default step;
    NSGA-II has populations of ``population`` (default 20)."""
    optuna = require_optuna()
    if kind not in SAMPLERS:
        raise ValueError(f"--sampler must be one of {', '.join(SAMPLERS)}, got {kind!r}")
    if kind == "cmaes" and n_objectives > 1:
        raise ValueError("--sampler cmaes optimises one objective; a pareto objective needs "
                         "--sampler nsga2 (or tpe)")  # fmt: skip
    x0 = space.defaults()

    def build(s: int) -> Any:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # ExperimentalWarning of optional arguments
            if kind == "tpe":
                return optuna.samplers.TPESampler(seed=s, multivariate=True,
                                                  n_startup_trials=10)  # fmt: skip
            if kind == "cmaes":
                return optuna.samplers.CmaEsSampler(x0=x0, seed=s, n_startup_trials=0,
                                                    warn_independent_sampling=False)  # fmt: skip
            return optuna.samplers.NSGAIISampler(population_size=population or 20, seed=s)

    class PerSlotSeed(optuna.samplers.BaseSampler):  # type: ignore[name-defined]
        """Delegates to a fresh ``kind`` sampler seeded from (seed, slot); for CMA-ES, which
        adds the trial's number to its seed, the trial it sees carries the slot as its
        number."""

        def __init__(self) -> None:
            self.slot: int | None = None
            self.inner = build(_trial_seed(seed, 0))

        def _slot(self, trial: Any) -> int:
            return int(trial.number if self.slot is None else self.slot)

        def _as_slot(self, trial: Any) -> Any:
            if kind != "cmaes":  # (TPE's constant liar finds the trial itself by its number)
                return trial
            t = copy.copy(trial)
            t.number = self._slot(trial)
            return t

        def before_trial(self, study: Any, trial: Any) -> None:
            self.inner = build(_trial_seed(seed, self._slot(trial)))
            self.inner.before_trial(study, self._as_slot(trial))

        def infer_relative_search_space(self, study: Any, trial: Any) -> Any:
            return self.inner.infer_relative_search_space(study, self._as_slot(trial))

        def sample_relative(self, study: Any, trial: Any, search_space: Any) -> Any:
            return self.inner.sample_relative(study, self._as_slot(trial), search_space)

        def sample_independent(self, study: Any, trial: Any, name: str, dist: Any) -> Any:
            return self.inner.sample_independent(study, self._as_slot(trial), name, dist)

        def after_trial(self, study: Any, trial: Any, state: Any, values: Any) -> None:
            self.inner.after_trial(study, trial, state, values)

        def reseed_rng(self) -> None:
            self.inner.reseed_rng()

    return PerSlotSeed()


def _bound_pruner() -> Any:
    optuna = require_optuna()

    class BoundPruner(optuna.pruners.BasePruner):  # type: ignore[name-defined]
        """Prune when the reported lower bound exceeds the best finished value."""

        def prune(self, study: Any, trial: Any) -> bool:
            step = trial.last_step
            if step is None:
                return False
            try:
                best = study.best_value
            except ValueError:  # no finished trial yet
                return False
            return bool(trial.intermediate_values[step] > best)

    return BoundPruner()


def open_study(storage: Any, name: str, directions: Sequence[str], sampler: Any) -> Any:
    """Create or load study ``name``; ``ValueError`` if it exists with other directions."""
    optuna = require_optuna()
    pruner = _bound_pruner() if len(directions) == 1 else optuna.pruners.NopPruner()
    study = optuna.create_study(storage=storage, study_name=name, directions=list(directions),
                                sampler=sampler, pruner=pruner, load_if_exists=True)  # fmt: skip
    if [d.name.lower() for d in study.directions] != [d.lower() for d in directions]:
        raise ValueError(f"--storage: study {name!r} exists with other objectives")
    return study


def slot_of(t: Any) -> int:
    """A trial's slot (module docstring); a trial of an older mwip without one: its number."""
    s = t.user_attrs.get("slot")
    return int(s) if isinstance(s, int) and not isinstance(s, bool) else int(t.number)


def finished_trials(study: Any) -> list[Any]:
    """The finished (complete or pruned) trials that count, one per slot (the first to
    finish it, by trial number), in slot order."""
    from optuna.trial import TrialState

    seen: dict[int, Any] = {}
    for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)):
        s = slot_of(t)
        if s not in seen or t.number < seen[s].number:
            seen[s] = t
    return [seen[s] for s in sorted(seen)]


def finished(study: Any) -> int:
    """Slots that count towards ``--trials``: finished (complete or pruned) ones."""
    return len(finished_trials(study))


def next_slot(trials: Sequence[Any], skip: Sequence[int] = ()) -> int:
    """The smallest slot that no finished, running or waiting trial holds, that has not
    failed twice with an error, and is not in ``skip``."""
    from optuna.trial import TrialState

    taken = set(skip)
    errors: Counter[int] = Counter()
    for t in trials:
        s = slot_of(t)
        if t.state == TrialState.FAIL:
            if t.user_attrs.get("error"):
                errors[s] += 1
        else:
            taken.add(s)
    taken.update(s for s, n in errors.items() if n >= 2)
    s = 0
    while s in taken:
        s += 1
    return s


def _owner() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _dead(owner: Any) -> bool:
    if not isinstance(owner, str) or ":" not in owner:
        return False
    host, _, pid = owner.rpartition(":")
    if host != socket.gethostname() or not pid.isdigit():
        return False
    if int(pid) == os.getpid():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def recover(study: Any, exclusive: bool) -> int:
    """Fail the stale ``RUNNING`` (and, ``exclusive``: this process alone uses the storage,
    ``WAITING``) trials (module docstring): their slots are free again. Returns how many."""
    from optuna.trial import TrialState

    optuna = require_optuna()
    n_failed = 0
    if not exclusive:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            optuna.storages.fail_stale_trials(study)
    states = (TrialState.RUNNING, TrialState.WAITING) if exclusive else (TrialState.RUNNING,)
    for t in study.get_trials(deepcopy=False, states=states):
        if exclusive or _dead(t.user_attrs.get("owner")):
            try:
                study._storage.set_trial_state_values(t._trial_id, state=TrialState.FAIL)
            except optuna.exceptions.UpdateFinishedTrialError:
                continue  # another process finished or failed it meanwhile
            n_failed += 1
    return n_failed


Objective = Callable[[dict[str, float], Callable[[int, float], None]], Outcome]


@contextmanager
def _heartbeat(study: Any, trial: Any) -> Iterator[None]:
    """Optuna's heartbeat of a running trial, where the storage has one (a shared study:
    other machines fail the trial once it stops)."""
    try:
        from optuna.storages._heartbeat import get_heartbeat_thread
    except ImportError:  # pragma: no cover - a later Optuna
        yield
        return
    with get_heartbeat_thread(trial._trial_id, study._storage):
        yield


def _check(out: Outcome) -> Any:
    for v in out.values:
        if not isinstance(v, int | float) or not math.isfinite(v):
            raise ValueError(f"objective value {v!r} is not finite")
    return out.values[0] if len(out.values) == 1 else list(out.values)


def optimise(
    study: Any,
    space: Space,
    objective: Objective,
    trials: int,
    *,
    exclusive: bool,
    progress: Callable[[Any, int, int], None] | None = None,
    batch: int = 1,
    objective_batch: Callable[[list[dict[str, float]]], list[Outcome]] | None = None,
) -> int:
    """Run trials until ``study`` holds ``trials`` finished slots; returns how many ran here.

    Trials are asked and told here (Optuna's ask-and-tell interface): slot 0 is the book's
    point, every other slot's parameters come from the sampler seeded from ``(seed, slot)``.

    ``batch = k > 1`` with ``objective_batch``: ``k`` trials are asked at once (a CMA-ES
    population: the sampler draws them from one generation), evaluated together by
    ``objective_batch(list of params)`` (one engine batch, one parameter vector per robot) and
    told; no pruning in this mode.

    ``objective(params, report)``: ``params`` maps the space's dimension names to values;
    ``report(step, bound)`` records a lower bound of the final cost after ``step`` chunks and
    raises Optuna's ``TrialPruned`` when the trial cannot become the best.

    An interruption (``KeyboardInterrupt``) fails the trials in flight (their slots are run
    again by the next run, with the same parameters) and propagates; an error of the
    objective is recorded on its trial (``error``) and propagates.
    """
    optuna = require_optuna()
    from optuna.trial import TrialState

    sampler = study.sampler

    def ask(slot: int) -> tuple[Any, dict[str, float]]:
        if slot == 0:
            waiting = study.get_trials(deepcopy=False, states=(TrialState.WAITING,))
            if not any(slot_of(t) == 0 for t in waiting):
                study.enqueue_trial(space.defaults(), user_attrs={"baseline": True, "slot": 0})
        if hasattr(sampler, "slot"):
            sampler.slot = slot
        with warnings.catch_warnings():  # ask/tell with a heartbeat: said for optimize()
            warnings.simplefilter("ignore")
            trial = study.ask()
        if "slot" not in trial.user_attrs:
            trial.set_user_attr("slot", slot)
        trial.set_user_attr("owner", _owner())
        params = {d.name: trial.suggest_float(d.name, d.lo, d.hi, log=d.log) for d in space.dims}
        return trial, params

    def duplicate(trial: Any) -> bool:
        """Whether another trial (of another process) held this trial's slot first."""
        if exclusive:
            return False
        s = slot_of(trial)
        return any(slot_of(t) == s and t.number < trial.number
                   and t.state != TrialState.FAIL
                   for t in study.get_trials(deepcopy=False))  # fmt: skip

    def fail(trial: Any, error: str | None = None) -> None:
        try:
            if error is not None:
                trial.set_user_attr("error", error[:500])
            study.tell(trial, state=TrialState.FAIL, skip_if_finished=True)
        except Exception:  # noqa: BLE001 - the next run fails it anyway
            pass

    def run_one(trial: Any, params: dict[str, float]) -> None:
        def report(step: int, bound: float) -> None:
            if len(study.directions) > 1:
                return
            trial.report(float(bound), int(step))
            if trial.should_prune():
                raise optuna.TrialPruned()

        try:
            with _heartbeat(study, trial):
                out = objective(params, report)
        except optuna.TrialPruned:
            study.tell(trial, state=TrialState.PRUNED)
            return
        except KeyboardInterrupt:
            fail(trial)
            raise
        except Exception as exc:
            fail(trial, f"{type(exc).__name__}: {exc}")
            raise
        if duplicate(trial):
            fail(trial, "duplicate")
            return
        for key, value in out.attrs.items():
            trial.set_user_attr(key, value)
        study.tell(trial, _check(out))

    ran = 0
    while True:
        recover(study, exclusive and ran == 0)
        done = finished(study)
        if done >= trials:
            return ran
        all_trials = study.get_trials(deepcopy=False)
        slot = next_slot(all_trials)
        if batch > 1 and objective_batch is not None and slot != 0:
            k = min(batch, trials - done)
            slots = [slot]
            while len(slots) < k:
                slots.append(next_slot(all_trials, skip=slots))
            asked: list[tuple[Any, dict[str, float]]] = []
            try:
                for s in slots:
                    asked.append(ask(s))
                outs = objective_batch([p for _, p in asked])
            except KeyboardInterrupt:
                for trial, _ in asked:
                    fail(trial)
                raise
            except Exception as exc:
                for trial, _ in asked:
                    fail(trial, f"{type(exc).__name__}: {exc}")
                raise
            for (trial, _), out in zip(asked, outs, strict=True):
                if duplicate(trial):
                    fail(trial, "duplicate")
                    continue
                for key, value in out.attrs.items():
                    trial.set_user_attr(key, value)
                study.tell(trial, _check(out))
            ran += len(asked)
        else:
            trial, params = ask(slot)
            run_one(trial, params)
            ran += 1
        if progress is not None:
            rows = finished_trials(study)
            if rows:
                last = max(rows, key=lambda t: t.number)
                progress(last, len(rows), trials)
