"""A tuning run from start to end: check everything, optimise, validate, write the results.

:func:`plan` validates the whole input and writes nothing (a bad controller, objective,
setting range, trial count, sampler or storage is a one-line ``ValueError``); :func:`execute`
then claims ``DIR``, holds it for the run (:func:`mwip.outdir.hold`), runs or continues the
study and writes, each atomically:

- ``DIR/best.toml``: the best trial's settings (:mod:`mwip.schema.settings`); pareto
  mode: the front member with the fewest failures, then the lowest first term;
- ``DIR/trials.csv``: every finished trial, by slot (number = the slot, state, values,
  success rate, parameters; :mod:`mwip.tune.study`): the same for a run killed and run again
  as for the uninterrupted run;
- ``DIR/validation.json``: :func:`mwip.tune.validate.validate`;
- ``DIR/tune.json``: the run's identity (controller, objective, sampler, seed, study name,
  storage) and summary; a different run into the same ``DIR`` is refused; a rerun of a
  finished run writes nothing;
- ``DIR/index.html`` and its figures (:mod:`mwip.tune.page`).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mwip.tune.evaluate import RobotSet, evaluate, robot_set
from mwip.tune.objective import Objective, load_objective, pareto_values, scalar_cost, successes
from mwip.tune.space import Space, build_space

__all__ = ["Plan", "plan", "execute", "MAX_TRIALS"]

MAX_TRIALS = 1_000_000


@dataclass(frozen=True)
class Plan:
    """A validated tuning run."""

    controller: str
    out: Path
    objective: Objective
    space: Space
    robots: RobotSet
    validation: RobotSet
    trials: int
    sampler: str
    seed: int
    storage_url: str
    user_storage: bool
    study_name: str
    identity: dict[str, Any]


def plan(
    controller: str,
    out: Path,
    objective: str = "robust",
    trials: int = 100,
    storage: str | None = None,
    sampler: str | None = None,
    seed: int = 0,
    force: bool = False,
    robot: Any = None,
) -> Plan:
    """Validate a run (module docstring); nothing is written."""
    from mwip.laws.registry import get
    from mwip.outdir import check
    from mwip.tune.study import SAMPLERS, close_storage, open_storage, require_optuna

    require_optuna()
    if isinstance(trials, bool) or not isinstance(trials, int) or not 1 <= trials <= MAX_TRIALS:
        raise ValueError(f"--trials must be an integer in [1, {MAX_TRIALS}], got {trials!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ValueError(f"--seed must be an integer in [0, 2^63), got {seed!r}")
    try:
        spec = get(controller)
    except ValueError as exc:
        raise ValueError(f"CONTROLLER: {exc}") from None
    obj = load_objective(objective, robot=robot)
    kind = sampler or ("tpe" if obj.mode == "scalar" else "nsga2")
    if kind not in SAMPLERS:
        raise ValueError(f"--sampler must be one of {', '.join(SAMPLERS)}, got {kind!r}")
    if kind == "cmaes" and obj.mode == "pareto":
        raise ValueError("--sampler cmaes optimises one objective; objective "
                         f"{obj.name!r} is pareto: use --sampler nsga2 or tpe")  # fmt: skip
    space = build_space(spec, obj.tune, dict(obj.ranges), obj.ratio)
    common = dict(plant=obj.plant, duration=obj.duration, success_theta=obj.success_theta,
                  robot=obj.robot)  # fmt: skip
    robots = robot_set(obj.campaign, obj.samples, obj.chunk, obj.seed, **common)
    vrobots = robot_set(obj.campaign, obj.validation_samples, obj.chunk, obj.validation_seed,
                        **common)  # fmt: skip
    out = check(out, force, command="tune")
    identity = {"controller": controller, "objective": obj.name,
                "objective_identity": obj.identity(), "sampler": kind, "seed": seed,
                "space": [[d.name, d.lo, d.hi, d.log] for d in space.dims]}  # fmt: skip
    digest = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()[:12]
    name = f"mwip-tune-{controller}-{digest}"
    record = out / "tune.json"
    if record.is_file():
        try:
            old = json.loads(record.read_text(encoding="utf-8")).get("identity")
        except (OSError, ValueError):
            old = None
        if old is not None and old != identity:
            raise ValueError(f"--out: {str(out)!r} holds another tuning run "
                             f"({old.get('controller')}, objective {old.get('objective')}, "
                             f"sampler {old.get('sampler')}, seed {old.get('seed')}); give "
                             "another folder")  # fmt: skip
    if storage is not None:
        close_storage(open_storage(storage))  # reachable? (before anything is written)
        url = storage
    else:
        url = f"sqlite:///{(out / 'study.db').absolute()}"
    return Plan(controller, out, obj, space, robots, vrobots, trials, kind, seed, url,
                storage is not None, name, identity)  # fmt: skip


def _outcome(p: Plan, met: dict[str, Any]) -> Any:
    from mwip.tune.study import Outcome

    obj, robots = p.objective, p.robots
    drive = robots.campaign.drive
    ok = successes(obj, met, drive)
    pv = pareto_values(obj, met, drive)
    attrs: dict[str, Any] = {"success_rate": float(ok.mean()),
                             "cost": scalar_cost(obj, met, drive),
                             "objectives": list(pv),
                             "plant_seconds": robots.plant_seconds}  # fmt: skip
    values = (attrs["cost"],) if obj.mode == "scalar" else pv
    return Outcome(tuple(values), attrs)


def _objective_fn(p: Plan) -> Callable[..., Any]:
    obj, robots = p.objective, p.robots
    drive = robots.campaign.drive

    def fn(params: dict[str, float], report: Callable[[int, float], None]) -> Any:
        import numpy as np

        settings = p.space.settings(params)
        parts = []
        fails = 0
        for b in range(robots.n_blocks):
            m = evaluate(p.controller, [settings], robots, blocks=[b])[0]
            parts.append(m)
            fails += int((~successes(obj, m, drive)).sum())
            if b + 1 < robots.n_blocks:
                report(b + 1, fails / robots.samples)
        met = {k: np.concatenate([q[k] for q in parts]) for k in parts[0]}
        return _outcome(p, met)

    return fn


def _objective_batch(p: Plan) -> Callable[..., Any]:
    """A population's outcomes from one batch per chunk of robots (:func:`evaluate` with
    several candidates: one parameter vector per robot)."""

    def fn(params_list: list[dict[str, float]]) -> list[Any]:
        settings = [p.space.settings(params) for params in params_list]
        return [_outcome(p, met) for met in evaluate(p.controller, settings, p.robots)]

    return fn


def population(sampler: str, n_dims: int) -> int:
    """Trials evaluated together: CMA-ES's default population ``4 + floor(3 ln n)`` (Hansen;
    Optuna's default), 1 (sequential, with pruning) for the other samplers."""
    import math

    return 4 + int(3 * math.log(max(n_dims, 1))) if sampler == "cmaes" else 1


def _trial_rows(study: Any, p: Plan) -> list[dict[str, Any]]:
    """The finished slots, in slot order (:func:`mwip.tune.study.finished_trials`): number =
    the slot, whatever trials were interrupted or failed on the way."""
    from mwip.tune.study import finished_trials, slot_of

    rows = []
    for t in finished_trials(study):
        bound = t.intermediate_values[t.last_step] if t.last_step is not None else None
        rows.append({"number": slot_of(t), "state": t.state.name,
                     "values": list(t.values) if t.values is not None else None,
                     "objectives": t.user_attrs.get("objectives"),
                     "success_rate": t.user_attrs.get("success_rate"), "bound": bound,
                     "params": dict(t.params),
                     "baseline": bool(t.user_attrs.get("baseline", False))})  # fmt: skip
    return rows


def _best(study: Any, p: Plan) -> Any:
    """The best finished trial: scalar mode the lowest cost (ties: the lowest slot); pareto
    mode the front member with the fewest failures, then the lowest first term, then slot."""
    from optuna.trial import TrialState

    from mwip.tune.page import pareto_front
    from mwip.tune.study import finished_trials, slot_of

    done = [t for t in finished_trials(study) if t.state == TrialState.COMPLETE]
    if not done:
        raise RuntimeError("no trial finished with a cost (every one was pruned)")
    if p.objective.mode == "scalar":
        return min(done, key=lambda t: (t.values[0], slot_of(t)))
    front = [done[i] for i in pareto_front([t.values for t in done])]
    return min(front, key=lambda t: (t.values[0], t.values[1] if len(t.values) > 1 else 0.0,
                                     slot_of(t)))  # fmt: skip


def _csv(rows: list[dict[str, Any]], p: Plan) -> str:
    import csv
    import io

    buf = io.StringIO()
    names = p.space.names()
    n_val = p.objective.n_objectives
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["number", "state", *[f"value{i}" for i in range(n_val)], "success_rate",
                *names])  # fmt: skip
    for r in rows:
        vals = r["values"] or [None] * n_val
        params = r["params"]
        w.writerow([r["number"], r["state"], *[_num(v) for v in vals], _num(r["success_rate"]),
                    *[_num(params.get(n)) for n in names]])  # fmt: skip
    return buf.getvalue()


def _num(v: Any) -> str:
    """A CSV cell: ``repr`` of a finite number (read back exactly), empty otherwise."""
    if v is None or isinstance(v, bool) or not isinstance(v, int | float):
        return ""
    return repr(v) if math.isfinite(v) else ""


def _importances(study: Any) -> dict[str, float]:
    import warnings

    import optuna

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            imp = optuna.importance.get_param_importances(
                study, target=(lambda t: t.values[0]) if len(study.directions) > 1 else None
            )
        return {k: float(v) for k, v in imp.items()}
    except (ValueError, RuntimeError, ZeroDivisionError):  # too few complete trials
        return {}


#: The files of a finished run (besides the study and tune.json).
OUTPUTS = ("best.toml", "trials.csv", "validation.json", "index.html")


def _record(out: Path) -> dict[str, Any] | None:
    try:
        doc = json.loads((out / "tune.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def execute(p: Plan, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Run (or continue) the plan; returns the summary written to ``tune.json``.

    A rerun of a finished run (the study holds ``--trials`` finished slots and every output
    file is there) writes nothing. Ctrl-C (``KeyboardInterrupt``) leaves every file as it was
    (the trials finished so far are in the study) and propagates; the database is closed on
    every way out (SQLite: no ``-wal``/``-shm`` left). A database error is an ``OSError``
    (a full disk, a file over its size limit) or a one-line ``RuntimeError``.
    """
    from mwip.outdir import claim, hold
    from mwip.tune.study import as_os_error, close_storage, open_storage, storage_errors

    claim(p.out, "tune")
    with hold(p.out):
        storage = open_storage(p.storage_url)
        # The storage is closed with no exception in flight: a Ctrl-C that lands while a
        # connection is checked out leaves it referenced by the frames of its traceback, and
        # SQLite keeps ``-wal``/``-shm`` while any connection is open (seen ~1 in 40 runs).
        error: BaseException | None = None
        try:
            return _execute(p, storage, log)
        except KeyboardInterrupt:
            error = KeyboardInterrupt()  # a fresh one, without the caught one's frames
        except storage_errors() as exc:
            error = as_os_error(exc, str(p.out / "study.db") if not p.user_storage
                                else p.storage_url)  # fmt: skip
        finally:
            close_storage(storage)
        raise error


def _execute(p: Plan, storage: Any, log: Callable[[str], None]) -> dict[str, Any]:
    from mwip.io import write_json_atomic, write_text_atomic
    from mwip.schema.settings import write_settings_file
    from mwip.tune.page import write_page
    from mwip.tune.study import finished, make_sampler, open_study, optimise, slot_of
    from mwip.tune.validate import validate

    t0 = time.perf_counter()
    old = _record(p.out)
    if old is None or old.get("identity") != p.identity:
        write_json_atomic(p.out / "tune.json", {"identity": p.identity, "study": p.study_name,
                                                "storage": p.storage_url})  # fmt: skip
    obj = p.objective
    directions = ["minimize"] * obj.n_objectives
    sampler = make_sampler(p.sampler, p.seed, p.space, obj.n_objectives)
    study = open_study(storage, p.study_name, directions, sampler)
    before = finished(study)
    summary_before = (old or {}).get("summary")
    if before >= p.trials:
        if (isinstance(summary_before, dict)
                and summary_before.get("trials_finished") == before
                and all((p.out / f).is_file() for f in OUTPUTS)):  # fmt: skip
            log(f"mwip tune: the study already holds {before} finished trials "
                f"(--trials {p.trials}); nothing to run, {p.out} is up to date")  # fmt: skip
            return dict(summary_before)
        log(f"mwip tune: the study already holds {before} finished trials "
            f"(--trials {p.trials}); nothing to run")  # fmt: skip
    elif before:
        log(f"mwip tune: continuing the study at {before} of {p.trials} finished trials")

    def progress(t: Any, done: int, total: int) -> None:
        what = (f"cost {t.values[0]:.5g}" if t.state.name == "COMPLETE" else
                f"pruned at {t.last_step} of {p.robots.n_blocks} chunks")  # fmt: skip
        rate = t.user_attrs.get("success_rate")
        ok = "" if rate is None else f", success {100 * rate:.1f} %"
        log(f"trial {slot_of(t)}: {what}{ok}  [{done}/{total}]")

    ran = optimise(study, p.space, _objective_fn(p), p.trials,
                   exclusive=not p.user_storage, progress=progress,
                   batch=population(p.sampler, len(p.space.dims)),
                   objective_batch=_objective_batch(p))  # fmt: skip
    tuning_s = time.perf_counter() - t0
    best = _best(study, p)
    n_done = finished(study)
    settings = p.space.settings(best.params)
    robot = "" if obj.robot is None else f" --robot ({obj.robot.name})"
    header = (f"mwip tune {p.controller} --objective {obj.name}{robot} --sampler {p.sampler} "
              f"--seed {p.seed}: trial {slot_of(best)} of {n_done}, "
              f"{'cost' if obj.mode == 'scalar' else 'objectives'} "
              f"{', '.join(f'{v:.6g}' for v in best.values)}, success "
              f"{100 * best.user_attrs.get('success_rate', math.nan):.1f} % on "
              f"{p.robots.samples} robots")  # fmt: skip
    rows = _trial_rows(study, p)
    log(f"mwip tune: validating on {p.robots.samples} tuning and {p.validation.samples} "
        "new robots")  # fmt: skip
    val = validate(p.controller, settings, obj, {"tuning": p.robots,
                                                  "validation": p.validation})  # fmt: skip
    labels = ["failure rate", *[t.metric for t in obj.terms]]
    summary = {"controller": p.controller, "objective": obj.name, "mode": obj.mode,
               "sampler": p.sampler, "seed": p.seed, "study": p.study_name,
               "storage": p.storage_url, "trials_finished": n_done,
               "trials_run_now": ran, "best_trial": slot_of(best),
               "best_values": list(best.values),
               "best_success_rate": best.user_attrs.get("success_rate"),
               "robots": p.robots.samples, "plant": p.robots.campaign.sensors,
               "tuning_wall_s": tuning_s}  # fmt: skip
    importances = _importances(study)
    # everything is computed: the files follow, each atomically, the record last
    write_settings_file(p.out / "best.toml", p.controller, settings, header)
    write_text_atomic(p.out / "trials.csv", _csv(rows, p))
    write_json_atomic(p.out / "validation.json", val)
    write_page(p.out, title=f"mwip tune {p.controller}: {obj.title or obj.name}",
               summary=summary, trials=rows, labels=labels, importances=importances,
               validation=val, best_settings=settings)  # fmt: skip
    write_json_atomic(p.out / "tune.json", {"identity": p.identity, "study": p.study_name,
                                            "storage": p.storage_url, "summary": summary})
    log(f"wrote {p.out / 'best.toml'}, {p.out / 'index.html'}, {p.out / 'trials.csv'}, "
        f"{p.out / 'validation.json'}")  # fmt: skip
    return summary
