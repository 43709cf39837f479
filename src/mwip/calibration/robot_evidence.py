"""A user's robot calibrated on what it did (``mwip twin calibrate FACTS --robot FILE``;
docs/twin_fit.md, "Calibrating your robot on what it did").

The robot file's ``[prior]`` declares its unknowns (ranges, log-uniform where declared, and
sources); the facts file (:mod:`mwip.calibration.facts_file`) states what the robot did on
the user's scenarios. The same sampler and the same evidence rules as the book calibration's
revision 7 (:mod:`mwip.calibration.comparison`, :mod:`mwip.calibration.compare`), on one
structure, the robot file's:

- **stage A**: ``draws`` prior draws in the prior's unit coordinates; **stage B**:
  ``search_draws`` draws from boxes around the stage-A twins meeting the largest consistent
  subset of the facts, a *search* for twins meeting more of them;
- every scenario of the facts runs on every twin (one batched twin run per scenario,
  :meth:`mwip.scenario.Scenario.run` with the twins' ``values``), and each fact is read from
  the board's measured signals (:mod:`mwip.calibration.measured`);
- ``Z = P(prior meets every fact)`` on stage A alone (Clopper-Pearson 95 %); what the
  robot's structure can meet (the most facts one twin meets, the facts no twin meets
  together with the others) on every twin evaluated. No twin meeting every fact: the
  structure is **rejected by** the facts outside the largest consistent subset, and no
  robot file is written;
- the twins meeting every fact, unweighted (stage B's draws are a search, not a posterior
  sample): per unknown its 5/50/95 % values, **identified** where their 90 % range is
  narrower than half the prior's (in unit coordinates, where the prior is uniform), a
  warning where more than half lies in the outer 5 % of the range at one wall;
- the **calibrated robot** (``robot.toml``): the robot file with its unknowns set to the
  most probable twin meeting every fact. With numeric facts: the largest kernel
  ``exp(-1/2 sum_j (e_j / s_j)^2)``, ``e_j = ln(x / value)``, ``s_j = ln(tolerance) / 2``
  (the book declaration's kernel) or ``e_j = x - value``, ``s_j = within / 2``. With
  qualitative facts only every such twin is equally probable: the one nearest (unit
  coordinates) to their median is written, and the page says so. Its ``[prior]`` stays the
  user's (a declared prior is not narrowed by the data it judges).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["calibrate_robot", "prepare", "analyse", "fact_table", "RESULT_FILE", "DRAWS_FILE",
           "IDENTIFIED"]  # fmt: skip

RESULT_FILE = "calibration.json"
DRAWS_FILE = "draws.parquet"
#: An unknown is identified where its consistent twins' 90 % range is narrower than this
#: share of its prior's (as the book declaration's ``verdict.identified``).
IDENTIFIED = 0.5

F64 = NDArray[np.float64]


def _scenarios(facts: Any, robot: Any, duration: float) -> list[Any]:
    """Every scenario of the facts, on ``robot`` (its body, design model and twin; a
    scenario's own robot is replaced, as ``mwip simulate --robot``), capped at ``duration``
    s when > 0."""
    from mwip.scenario import load_scenario

    out = []
    for path in facts.scenarios:
        sc = load_scenario(path)
        if not sc.twin:
            raise ValueError(f"scenario {path.name!r}: a fact is about the robot's board: the "
                             "scenario must run on the twin ([scenario] twin = true)")  # fmt: skip
        sc = sc.with_overrides(robot=robot, plant=robot.body, design=robot.design)
        if duration > 0:
            sc = sc.with_overrides(duration=min(float(sc.duration), duration))
        out.append(sc)
    return out


def _window(fact: Any, duration: float) -> tuple[float, float] | None:
    if fact.window is None:
        return None
    lo, hi = fact.window
    return (min(lo, duration / 2), min(hi, duration))


def _chunk(args: tuple[list[Any], tuple[Any, ...], dict[str, F64], bool]) -> dict[str, F64]:
    """Every scenario on one chunk of twins (a worker's job): the facts' columns and each
    scenario's ``run<k>.t_end``."""
    from mwip.calibration.measured import measure

    scenarios, facts, values, capped = args
    paths = list(dict.fromkeys(f.scenario for f in facts))
    cols: dict[str, F64] = {}
    for k, sc in enumerate(scenarios):
        res = sc.run(values=values, drive_logs=False)
        ok = np.asarray(res.status == "ok")
        cols[f"run{k}.t_end"] = np.asarray(res.t_end, dtype=float)
        y = None
        for f in facts:
            if paths.index(f.scenario) != k:
                continue
            if f.metric is None:
                cols[f.column] = ok.astype(float)
                continue
            if y is None:
                y = res.series()["y_meas"]
            win = _window(f, float(sc.duration)) if capped else f.window
            cols[f.column] = measure(f.metric, res.t, y, ok, window=win,
                                     reference=f.reference,
                                     radius=float(np.mean(sc.design.r)))  # fmt: skip
    return cols


def _fact_names(facts: Any) -> list[str]:
    names = [f.name for f in facts.facts]
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if names.count(n) == 1 else f"{n}#{seen[n]}")
    return out


def fact_table(df: Any, facts: Any) -> Any:
    """The :class:`~mwip.calibration.posterior.Facts` of the rows ``df``: ``S`` which facts
    each twin meets, ``log_err`` each numeric fact's normalised error ``e_j / s_j`` (module
    docstring; ``nan`` where the twin fell)."""
    from mwip.calibration.posterior import Facts

    S, errs = [], []
    for f in facts.facts:
        x = df[f.column].to_numpy(dtype=float)
        if f.metric is None:
            S.append(x == (1.0 if f.stands else 0.0))
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            if f.tolerance is not None:
                e = np.where(x > 0, np.log(x / f.value), np.nan) / (np.log(f.tolerance) / 2)
            else:
                e = (x - f.value) / (f.within / 2)
        errs.append(e)
        S.append(np.isfinite(e) & (np.abs(e) <= 2.0 + 1e-9))
    n = len(df)
    err = np.column_stack(errs) if errs else np.zeros((n, 0))
    return Facts(tuple(_fact_names(facts)), np.column_stack(S).astype(bool), err)


def _member(structure: Any, df: Any, f: Any, sel: NDArray[np.bool_]) -> tuple[int, str]:
    """The row of the calibrated robot among the rows ``sel`` meeting every fact, and how it
    was chosen (module docstring)."""
    rows = np.flatnonzero(sel)
    if f.log_err.shape[1]:
        k = np.sum(f.log_err[rows] ** 2, axis=1)
        return int(rows[int(np.argmin(k))]), (
            "the twin meeting every fact with the largest kernel exp(-1/2 sum (e/s)^2) of its "
            "numeric facts")
    u = df[[f"u.{n}" for n in structure.prior.names]].to_numpy(dtype=float)[rows]
    d = np.sum(np.abs(u - np.median(u, axis=0)), axis=1)
    return int(rows[int(np.argmin(d))]), (
        "the facts are all qualitative, so every twin meeting them is equally probable: the "
        "one nearest (in the prior's unit coordinates) to their median")


def analyse(table: Any, structure: Any, facts: Any) -> dict[str, Any]:
    """The result document from the per-twin rows ``table`` (stages A and B)."""
    from mwip.calibration.comparison import _marginals, _offset, structure_evidence_of

    f = fact_table(table, facts)
    se = structure_evidence_of(structure.name, table, f)
    in_a = (table["stage"] == "A").to_numpy()
    accepted = se.accepted
    marg = _marginals(structure, table, accepted, np.ones(len(table)))
    for name, m in marg.items():
        unk = structure.prior[name]
        q = np.asarray(unk.to_unit(np.array([m["q05"], m["q95"]])), dtype=float)
        m["unit_width_90"] = float(q[1] - q[0])
        m["identified"] = bool(q[1] - q[0] < IDENTIFIED * 0.9)
    share_a = {n: float(np.mean(f.S[in_a, j])) for j, n in enumerate(f.names)}
    doc: dict[str, Any] = {
        "title": facts.title, "robot": structure.title, "structure": se.to_json(),
        "facts": [{"name": n, "what": fact.describe(), "source": fact.source,
                   "prior_share": share_a[n]}
                  for n, fact in zip(f.names, facts.facts, strict=True)],  # fmt: skip
        "stages": {s: int((table["stage"] == s).sum()) for s in ("A", "B")},
        "consistent": int(accepted.sum()), "marginals": marg,
        "offset": _offset(structure, table, accepted, np.ones(len(table))),
        "unknowns": list(structure.prior.names),
    }
    if accepted.any():
        row, how = _member(structure, table, f, accepted)
        u = table[[f"u.{n}" for n in structure.prior.names]].to_numpy(dtype=float)[row]
        x = structure.from_unit(u[None, :])[0]
        doc["member"] = {"sample": int(table["sample"].iloc[row]), "how": how,
                         "values": {n: float(v) for n, v in
                                    zip(structure.prior.names, x, strict=True)
                                    if not structure.prior[n].fixed}}  # fmt: skip
    return doc


def _evaluate(structure: Any, scenarios: list[Any], facts: Any, jobs: int,
              capped: bool) -> Callable[[F64], dict[str, F64]]:  # fmt: skip
    from mwip.calibration.sample import map_chunks

    def run(u: F64) -> dict[str, F64]:
        values = structure.values(structure.from_unit(u))
        n = len(u)
        parts = max(1, min(jobs, n))
        edges = np.linspace(0, n, parts + 1).round().astype(int)
        chunks = [(scenarios, facts.facts, {k: v[a:b] for k, v in values.items()}, capped)
                  for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]  # fmt: skip
        res = map_chunks(_chunk, chunks, jobs)
        return {k: np.concatenate([r[k] for r in res]) for k in res[0]}

    return run


def prepare(facts_path: Path, robot: Any, robot_label: str,
            duration: float = 0.0) -> tuple[Any, Any, list[Any]]:  # fmt: skip
    """The facts file, the robot's structure and the scenarios on it, checked before anything
    is written (``ValueError``, one line, for bad input)."""
    from mwip.calibration.facts_file import load_facts
    from mwip.calibration.structures import Structure

    facts = load_facts(facts_path)
    if not any(not u.fixed for u in robot.twin.prior.unknowns):
        raise ValueError(f"{robot_label}: its [prior] leaves no value unknown (every low = "
                         "high): nothing to calibrate")  # fmt: skip
    structure = Structure(robot.name, f"{robot.name} ({robot_label})", robot.twin)
    return facts, structure, _scenarios(facts, robot, duration)


def calibrate_robot(out: Path, facts_path: Path, robot: Any, *, robot_label: str,
                    jobs: int = 1, draws: int | None = None, search_draws: int | None = None,
                    duration: float = 0.0,
                    note: Callable[[str], None] | None = None) -> dict[str, Any]:  # fmt: skip
    """Sample (or resume) the robot's prior against the facts into ``out`` and write
    ``calibration.json``, ``calibration.md``, ``draws.parquet`` and, where a twin meets every
    fact, ``robot.toml`` (module docstring). ``ValueError`` (one line) for bad input."""
    import pandas as pd

    from mwip.calibration.comparison import search
    from mwip.calibration.facts_file import FACTOR
    from mwip.calibration.robot_evidence_report import report_md
    from mwip.calibration.structures import SamplePlan
    from mwip.io import json_text, write_parquet_atomic, write_text_atomic

    facts, structure, scenarios = prepare(facts_path, robot, robot_label, duration)
    plan = SamplePlan(facts.draws, facts.search_draws, FACTOR, facts.seed, facts.block)
    stamp = _stamp(facts, robot, duration)
    store = out / "draws"
    old = out / "identity.txt"
    if store.exists() and (not old.exists() or old.read_text() != stamp):
        raise ValueError(f"--out: {str(out)!r} holds another calibration's draws (another robot, "
                         "facts file or --duration): give a new folder")  # fmt: skip
    write_text_atomic(old, stamp)
    run = _evaluate(structure, scenarios, facts, jobs, duration > 0)
    table = search(structure, plan, store, run, lambda df: fact_table(df, facts),
                   prior_draws=draws, kernel_draws=search_draws, label=robot.name,
                   note=note)  # fmt: skip
    write_parquet_atomic(out / DRAWS_FILE, table)
    table = pd.read_parquet(out / DRAWS_FILE)
    doc = analyse(table, structure, facts)
    doc["evidence_file"] = str(facts.path)
    doc["robot_file"] = robot_label
    doc["duration_cap"] = duration or None
    target = out / "robot.toml"
    if "member" in doc:
        write_text_atomic(target, _robot_text(robot, doc, facts))
    elif target.exists():
        target.unlink()  # a resumed run whose larger sample rejects: no stale robot
    write_text_atomic(out / RESULT_FILE, json_text(doc))
    write_text_atomic(out / "calibration.md", report_md(doc))
    return doc


def _stamp(facts: Any, robot: Any, duration: float) -> str:
    """What the stored draws depend on: the facts file, its scenarios, the robot, the cap."""
    h = hashlib.sha256(facts.path.read_bytes())
    for p in facts.scenarios:
        h.update(p.read_bytes())
    h.update(robot.digest().encode())
    h.update(repr(float(duration)).encode())
    return h.hexdigest() + "\n"


def _robot_text(robot: Any, doc: dict[str, Any], facts: Any) -> str:
    """The calibrated robot file: the most probable twin's values, their sources, the notes."""
    from mwip.robot import robot_to_toml

    m = doc["member"]
    s = doc["structure"]
    src = (f"calibrated on {facts.path.name}: {doc['consistent']} of {s['searched']} twins meet "
           f"all {len(doc['facts'])} facts; {m['how']} (calibration.md)")  # fmt: skip
    values = m["values"]
    cal = robot.with_values(values).with_sources({n: src for n in values})
    note = (f"Calibrated with `mwip twin calibrate {facts.path.name}` on "
            f"{len(doc['facts'])} facts ({facts.title}): {src}.")  # fmt: skip
    if robot.notes:
        note += "\nBefore this calibration: " + robot.notes
    return robot_to_toml(replace(cal, notes=note))
