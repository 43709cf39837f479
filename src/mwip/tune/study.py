"""The Optuna study of a tuning run: storage, samplers, pruning, resuming.

Storage. Any Optuna RDB URL (``sqlite:///DIR/study.db`` by default); several processes may
work on one study through a shared database (each with its own ``--out``). Every state change
of a trial is one database transaction, so ``kill -9`` at any moment leaves the finished trials
as they were and at most the trials in flight ``RUNNING``.

Resuming. Before every trial, trials left ``RUNNING`` by a process that no longer runs are
marked failed: with the default storage every ``RUNNING`` trial found at start (the output
folder is held by one process, :func:`mwip.outdir.hold`); with a shared one those of a dead
process on this machine (each trial records ``host:pid``) and, through Optuna's heartbeat,
those of any machine that has not been heard from for :data:`GRACE_S`. Every failed trial is
then retried once, with the same parameters (``retry_of``). The run stops when the study holds
``trials`` finished (complete or pruned) trials: the same command continues a killed run, and
the trial count continues from where it was; a finished study runs nothing more.

Seeds. The sampler is rebuilt for every trial, seeded from ``(seed, trial number)``, so a
trial's parameters depend on the seed, its number and the trials finished before it only: a
sequential run is reproducible, and processes sharing a study draw different points. (CMA-ES
and NSGA-II keep their state in the storage, TPE has none beyond the trials.) Trial 0 is the
book's settings, so the best trial is never worse than the book on the tuning robots.

Pruning (one objective). A trial reports, after each chunk of robots, a lower bound of its
final cost: ``f / N`` with ``f`` its failures so far (the cost is ``(f + g) / N``, ``g`` in
``[0, 1)``, :mod:`mwip.tune.objective`); it is pruned as soon as that bound exceeds the best
finished cost, i.e. once it has failed on more robots than the best trial. A pruned trial
could never have become the best, so pruning changes no result, only the time.
"""

from __future__ import annotations

import math
import os
import socket
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mwip.tune.space import Space

__all__ = ["require_optuna", "open_storage", "open_study", "make_sampler", "optimise",
           "Outcome", "recover", "finished", "SAMPLERS", "GRACE_S"]  # fmt: skip

SAMPLERS: tuple[str, ...] = ("tpe", "cmaes", "nsga2")
#: Heartbeat of a running trial (s) and the silence after which another process may fail it.
HEARTBEAT_S = 30
GRACE_S = 120


def require_optuna() -> Any:
    """The optuna module, or a one-line ``ValueError`` saying how to install it."""
    try:
        import optuna
    except ImportError:
        raise ValueError("mwip tune needs Optuna and cmaes: pip install 'mwip[tune]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def open_storage(url: str, heartbeat: bool = True) -> Any:
    """An Optuna RDB storage at ``url``; ``ValueError`` naming ``--storage`` if it cannot be
    opened (bad URL, missing driver, unreachable server, unwritable file)."""
    optuna = require_optuna()
    kw: dict[str, Any] = {}
    if heartbeat:
        kw.update(heartbeat_interval=HEARTBEAT_S, grace_period=GRACE_S)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            storage = optuna.storages.RDBStorage(url, **kw)
    except Exception as exc:  # noqa: BLE001 - SQLAlchemy/driver errors of every kind
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise ValueError(f"--storage: cannot open {url!r}: {first[:200]}") from None
    if url.startswith("sqlite"):
        _sqlite_wal(storage.engine)
    return storage


def _sqlite_wal(engine: Any) -> None:
    """SQLite in write-ahead-log mode with ``synchronous = NORMAL``: a commit is a write to
    the log, not an ``fsync`` (Optuna commits every suggestion and attribute: ~30 per trial,
    ~10 ms each with ``fsync``). A committed transaction survives the death of the process
    (``kill -9``: the data is in the operating system's hands); only a power loss may lose
    the last ones, never corrupt the file."""
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


def _trial_seed(seed: int, number: int) -> int:
    ss = np.random.SeedSequence(int(seed), spawn_key=(int(number),))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def make_sampler(kind: str, seed: int, space: Space, n_objectives: int = 1,
                 population: int | None = None) -> Any:  # fmt: skip
    """A sampler of ``kind`` (:data:`SAMPLERS`) reseeded for every trial (module docstring).

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

    class PerTrialSeed(optuna.samplers.BaseSampler):  # type: ignore[name-defined]
        """Delegates to a fresh ``kind`` sampler seeded from (seed, trial number)."""

        def __init__(self) -> None:
            self.inner = build(_trial_seed(seed, 0))

        def before_trial(self, study: Any, trial: Any) -> None:
            self.inner = build(_trial_seed(seed, trial.number))
            self.inner.before_trial(study, trial)

        def infer_relative_search_space(self, study: Any, trial: Any) -> Any:
            return self.inner.infer_relative_search_space(study, trial)

        def sample_relative(self, study: Any, trial: Any, search_space: Any) -> Any:
            return self.inner.sample_relative(study, trial, search_space)

        def sample_independent(self, study: Any, trial: Any, name: str, dist: Any) -> Any:
            return self.inner.sample_independent(study, trial, name, dist)

        def after_trial(self, study: Any, trial: Any, state: Any, values: Any) -> None:
            self.inner.after_trial(study, trial, state, values)

        def reseed_rng(self) -> None:
            self.inner.reseed_rng()

    return PerTrialSeed()


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


def finished(study: Any) -> int:
    """Trials that count towards ``--trials``: complete or pruned."""
    from optuna.trial import TrialState

    return len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)))


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


def recover(study: Any, exclusive: bool) -> tuple[int, int]:
    """Fail the stale ``RUNNING`` trials and retry every failed trial once (module
    docstring); ``exclusive``: this process alone uses the storage. Returns (failed, retried)."""
    from optuna.trial import TrialState

    n_failed = 0
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        if exclusive or _dead(t.user_attrs.get("owner")):
            study.tell(t.number, state=TrialState.FAIL, skip_if_finished=True)
            n_failed += 1
    trials = study.get_trials(deepcopy=False)
    retried = {t.user_attrs.get("retry_of") for t in trials}
    n_retried = 0
    for t in trials:
        if (t.state == TrialState.FAIL and "retry_of" not in t.user_attrs
                and t.number not in retried and t.params):  # fmt: skip
            attrs = {k: v for k, v in t.user_attrs.items() if k in ("baseline",)}
            study.enqueue_trial(dict(t.params), user_attrs={**attrs, "retry_of": t.number},
                                skip_if_exists=False)  # fmt: skip
            n_retried += 1
    return n_failed, n_retried


Objective = Callable[[dict[str, float], Callable[[int, float], None]], Outcome]


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
    """Run trials until ``study`` holds ``trials`` finished ones; returns how many ran here.

    ``batch = k > 1`` with ``objective_batch``: ``k`` trials are asked at once (a CMA-ES
    population: the sampler draws them from one generation), evaluated together by
    ``objective_batch(list of params)`` (one engine batch, one parameter vector per robot) and
    told; no pruning in this mode.

    ``objective(params, report)``: ``params`` maps the space's dimension names to values;
    ``report(step, bound)`` records a lower bound of the final cost after ``step`` chunks and
    raises Optuna's ``TrialPruned`` when the trial cannot become the best.
    """
    optuna = require_optuna()
    from optuna.trial import TrialState

    if not study.get_trials(deepcopy=False):
        study.enqueue_trial(space.defaults(), user_attrs={"baseline": True})

    def func(trial: Any) -> Any:
        trial.set_user_attr("owner", _owner())
        params = {d.name: trial.suggest_float(d.name, d.lo, d.hi, log=d.log) for d in space.dims}

        def report(step: int, bound: float) -> None:
            if len(study.directions) > 1:
                return
            trial.report(float(bound), int(step))
            if trial.should_prune():
                raise optuna.TrialPruned()

        out = objective(params, report)
        for key, value in out.attrs.items():
            trial.set_user_attr(key, value)
        for v in out.values:
            if not math.isfinite(v):
                raise ValueError(f"objective value {v!r} is not finite")
        return out.values[0] if len(out.values) == 1 else tuple(out.values)

    def tell(trial: Any, out: Outcome) -> None:
        for key, value in out.attrs.items():
            trial.set_user_attr(key, value)
        for v in out.values:
            if not math.isfinite(v):
                raise ValueError(f"objective value {v!r} is not finite")
        study.tell(trial, out.values[0] if len(out.values) == 1 else list(out.values))

    ran = 0
    while True:
        recover(study, exclusive and ran == 0)
        done = finished(study)
        if done >= trials:
            return ran
        pending = [t for t in study.get_trials(deepcopy=False) if t.state == TrialState.WAITING]
        if batch > 1 and objective_batch is not None and not pending:
            with warnings.catch_warnings():  # ask/tell: the owner attribute marks the trials
                warnings.filterwarnings("ignore", message="Heartbeat of storage")
                asked = [study.ask() for _ in range(min(batch, trials - done))]
            params = []
            for trial in asked:
                trial.set_user_attr("owner", _owner())
                params.append({d.name: trial.suggest_float(d.name, d.lo, d.hi, log=d.log)
                               for d in space.dims})  # fmt: skip
            for trial, out in zip(asked, objective_batch(params), strict=True):
                tell(trial, out)
            ran += len(asked)
        else:  # one trial (and the queued ones: the baseline, retries), with pruning
            study.optimize(func, n_trials=1, catch=(), gc_after_trial=False)
            ran += 1
        if progress is not None:
            last = study.get_trials(deepcopy=False)[-1]
            for t in reversed(study.get_trials(deepcopy=False)):
                if t.state in (TrialState.COMPLETE, TrialState.PRUNED):
                    last = t
                    break
            progress(last, finished(study), trials)
