"""The book calibration's revisions 6-8: the declared structures sampled, and compared by
their evidence (``mwip twin calibrate book``; ``book-structures.toml``).

For each structure ``S`` (:mod:`mwip.calibration.structures`), in its prior's unit
coordinates (where the prior is uniform, density 1):

- **stage A**: ``prior_draws`` prior draws, draw ``s`` from the generator of ``(seed, s)``;
- **stage B**: ``kernel_draws`` draws (indices from :data:`STAGE_B`) from the box-kernel
  mixture (:class:`mwip.calibration.mixture.KernelMixture`, one family, half-widths
  ``factor`` x the seeds' standard deviation) around the stage-A draws that meet ``S``'s
  largest consistent subset of stage A: a **search** for twins that meet more facts.

Revision 7 (``book-structures.toml``): stage B is not pooled with stage A by importance
weights, as revision 6 declared. Its boxes are centred on the very stage-A draws they would
reweight, so the balance-heuristic weights of those draws collapse and the pool
underestimates ``Z`` by orders of magnitude (``tests/test_calibration_structures.py``:
synthetic truth ``Z = 0.033`` came out near ``1e-6``). So:

- ``Z = P(prior meets every fact)`` is estimated on stage A alone (prior draws: the share
  meeting them, Clopper-Pearson's 95 % interval; no draw: its upper bound);
- what a structure can meet (the facts one twin meets together, the largest consistent
  subset, the facts that reject it, whether any twin meets them all) is read on every twin
  stages A and B evaluated (existence needs no weights);
- the marginals, the pitch estimate's offset, the facts' shares and each held-out claim's
  share are read on the twins found meeting the largest consistent subset, A and B alike,
  **unweighted**: a description of the twins found, not a posterior (stage B's draws are not
  drawn from one).

Revision 8 (``book-structures.toml``, ``[revision_8]``): where stages A and B found no twin
meeting every fact, **stage C**, a directed search (:mod:`mwip.calibration.directed`: an
evolution strategy minimising the facts' violation), asks the existence question harder
before a structure is called rejected. Its twins count for existence and are described with
the others; ``Z`` stays stage A's.

Revision 9 (``[revision_9]``): where stages A-C found a twin meeting every fact, **stage D**
(:mod:`mwip.calibration.importance`) draws from a defensive box-kernel proposal around those
twins, fixed before its draws, with exact importance weights ``w = 1 / q``: ``Z`` is then
stage D's importance estimate, and the structure's posterior is stage D's twins meeting
every fact weighted by ``w`` (the marginals, the offset, the facts' and held-out claims'
shares read on it, weighted). The default robot is the most probable member of the most
probable structure (:func:`member_robot_text`, ``robot.toml``).

Every Chapter 6 run on every draw (:func:`mwip.calibration.runs.run_batch` on ``S``'s twin),
in blocks stored as they finish (a rerun resumes; a draw depends on ``(seed, index)`` alone,
so the columns do not depend on blocks or jobs). The per-draw table of every structure is
written as one compact file (``draws.parquet``: the columns the facts and claims read), and
every number of the result is computed from that file alone, so ``--replay FILE`` rebuilds
it byte for byte.

The comparison (:mod:`mwip.calibration.compare`): each structure's evidence with its
interval, Bayes factors, posterior probabilities, and per structure each unknown's spread
(a warning where more than half of it lies in the outer 5 % of its range at a wall), the
pitch estimate's constant offset ``gyro offset x fusion tau`` where the structure has one (a
complementary filter without zeroing: :mod:`mwip.hardware.fusion`), each held-out claim's
verdict per structure ("not judgeable on S" where it needs a fact that rejects ``S``) and
averaged by the posterior probabilities.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["run_comparison", "analyse_table", "member_robot_text", "STAGE_B", "DRAWS_FILE",
           "RESULT_FILE", "ROBOT_FILE", "STATUS_FILE"]  # fmt: skip

#: Stage B's draw indices start here (stage A's at 0).
STAGE_B = 1_000_000
DRAWS_FILE = "draws.parquet"
RESULT_FILE = "structures.json"
#: Revision 9's default robot (the most probable member of the most probable structure).
ROBOT_FILE = "robot.toml"
#: Its status document (:mod:`mwip.calibration.default_status`; ``mwip/hardware/book-twin.json``).
STATUS_FILE = "book-twin.json"
#: A marginal is "on a prior wall" when more than half its posterior mass lies in the outer
#: ``WALL`` of its range (unit coordinates) at one end.
WALL = 0.05


def _unit_draws(seed: int, idx: Any, d: int) -> NDArray[np.float64]:
    from mwip.campaign.sampling import sample_rng

    return np.array([sample_rng(seed, int(i)).random(d) for i in idx]).reshape(len(idx), d)


def _needed(cols: dict[str, Any], ev: Any) -> list[str]:
    """The columns the facts and claims read (the replay file keeps only these)."""
    from mwip.calibration.claims import CLAIMS

    runs = {r for c in CLAIMS for r in c.runs}
    keep = {n.key for n in ev.numbers}
    for k in cols:
        run = k.rsplit(".", 1)[0]
        if k.endswith(".stands") or run in runs:
            keep.add(k)
    return sorted(keep & set(cols))


def _blocks(names: Sequence[str], label: str, stage: str, u: NDArray[np.float64],
            idx: NDArray[np.int64], store: Path, block: int,
            run: Callable[[NDArray[np.float64]], dict[str, Any]],
            note: Callable[[str], None] | None) -> Any:  # fmt: skip
    """``run`` (unit coordinates (n, D) -> the columns to keep) on the draws ``u`` (indices
    ``idx``), block by block into ``store`` (kept blocks are read back): a DataFrame of
    ``sample``, ``u.<name>`` per unknown of ``names``, the columns."""
    import pandas as pd

    from mwip.io import write_parquet_atomic

    store.mkdir(parents=True, exist_ok=True)
    parts = []
    nb = -(-len(idx) // block)
    for b in range(nb):
        path = store / f"{stage}-{b:04d}.parquet"
        if path.exists():
            parts.append(pd.read_parquet(path))
            continue
        sl = slice(b * block, min((b + 1) * block, len(idx)))
        data: dict[str, Any] = {"sample": idx[sl]}
        data.update({f"u.{n}": u[sl, j] for j, n in enumerate(names)})
        data.update(run(u[sl]))
        df = pd.DataFrame(data)
        write_parquet_atomic(path, df)
        parts.append(df)
        if note is not None:
            note(f"{label} stage {stage}: block {b + 1}/{nb} ({sl.stop} of {len(idx)} twins)")
    return pd.concat(parts, ignore_index=True)


def _facts(df: Any, ev: Any) -> Any:
    from mwip.calibration.posterior import facts
    from mwip.calibration.runs import run_names

    cols = {c: df[c].to_numpy(dtype=float) for c in df.columns
                if c not in ("structure", "stage")}  # fmt: skip
    return facts(cols, run_names(), ev)


def search(structure: Any, plan: Any, store: Path,
           run: Callable[[NDArray[np.float64]], dict[str, Any]],
           facts_of: Callable[[Any], Any], *, prior_draws: int | None = None,
           kernel_draws: int | None = None, label: str | None = None,
           note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Stages A and B (module docstring) of ``structure`` (its ``prior``, ``from_unit``) into
    ``store``: ``run`` maps unit coordinates (n, D) to the columns to keep, ``facts_of`` a
    stage's rows to their :class:`~mwip.calibration.posterior.Facts`. Both stages' rows
    with a ``stage`` column."""
    import pandas as pd

    from mwip.calibration.mixture import KernelMixture
    from mwip.calibration.posterior import consistent_subset

    names = structure.prior.names
    label = structure.name if label is None else label
    d = len(structure.prior)
    na = plan.prior_draws if prior_draws is None else int(prior_draws)
    nb = plan.kernel_draws if kernel_draws is None else int(kernel_draws)
    ia = np.arange(na, dtype=np.int64)
    free = structure.prior.bounds[:, 1] > structure.prior.bounds[:, 0]
    u0 = _unit_draws(plan.seed, ia, d) * free  # a fixed unknown's coordinate is 0
    a = _blocks(names, label, "A", u0, ia, store, plan.block, run, note)
    a["stage"] = "A"
    ua = a[[f"u.{n}" for n in names]].to_numpy(dtype=float)
    unit = np.column_stack([np.zeros(d), free.astype(float)])
    if nb == 0:
        return a
    f = facts_of(a)
    mask, _ = consistent_subset(f)
    seeds = ua[np.all(f.S[:, mask], axis=1)]
    mix = KernelMixture.fit(seeds, unit, [plan.factor])
    ib = STAGE_B + np.arange(nb, dtype=np.int64)
    ub = mix.draw(plan.seed, ib.tolist())
    b = _blocks(names, label, "B", ub, ib, store, plan.block, run, note)
    b["stage"] = "B"
    return pd.concat([a, b], ignore_index=True)


def sample_structure(structure: Any, plan: Any, store: Path, ev: Any, *, jobs: int = 1,
                     duration: float = 0.0, prior_draws: int | None = None,
                     kernel_draws: int | None = None,
                     note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Stages A and B of ``structure`` (module docstring) into ``store``: every Chapter 6
    run on each draw (:func:`mwip.calibration.sample.evaluate`); both stages' rows with a
    ``stage`` column."""
    run = _book_run(structure, ev, jobs, plan.block, duration)
    return search(structure, plan, store, run, lambda df: _facts(df, ev),
                  prior_draws=prior_draws, kernel_draws=kernel_draws, note=note)  # fmt: skip


def _book_run(structure: Any, ev: Any, jobs: int, block: int,
              duration: float) -> Callable[[NDArray[np.float64]], dict[str, Any]]:  # fmt: skip
    """Unit coordinates -> every Chapter 6 run's kept columns on ``structure``'s twins."""
    from mwip.calibration.sample import evaluate

    def run(u: NDArray[np.float64]) -> dict[str, Any]:
        x = structure.from_unit(u)
        cols = evaluate(structure.values(x), jobs=jobs, block=block, duration=duration,
                        twin=structure.twin)  # fmt: skip
        return {k: cols[k] for k in _needed(cols, ev)}

    return run


def directed_stage(structure: Any, rows: Any, directed: Any, store: Path, ev: Any, *,
                   block: int, jobs: int = 1, duration: float = 0.0,
                   note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Revision 8's stage C (:mod:`mwip.calibration.directed`) of ``structure`` after its
    stage A and B ``rows``, where none of them meets every fact; else no row."""
    from mwip.calibration.directed import directed_search, violation

    def score(df: Any) -> NDArray[np.float64]:
        return violation(_facts(df, ev), ev.log_tolerance)

    if directed is None or directed.generations == 0 or np.any(score(rows) == 0.0):
        return rows.iloc[:0]
    run = _book_run(structure, ev, jobs, block, duration)
    return directed_search(structure, directed, store, rows, run, score, block=block,
                           note=note)  # fmt: skip


def importance_stage(structure: Any, rows: Any, plan: Any, store: Path, ev: Any, *,
                     block: int, jobs: int = 1, duration: float = 0.0,
                     note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Revision 9's stage D (:mod:`mwip.calibration.importance`) of ``structure`` after its
    stage A-C ``rows``, where one of them meets every fact; else no row."""
    from mwip.calibration.importance import importance_search

    if plan is None:
        return rows.iloc[:0]
    run = _book_run(structure, ev, jobs, block, duration)
    return importance_search(structure, plan, store, rows, run,
                             lambda df: np.all(_facts(df, ev).S, axis=1), block=block,
                             note=note)  # fmt: skip


def _marginals(structure: Any, df: Any, sel: NDArray[np.bool_],
               w: NDArray[np.float64]) -> dict[str, Any]:  # fmt: skip
    from mwip.calibration.posterior import weighted_quantile

    out: dict[str, Any] = {}
    if not sel.any():
        return out
    for unk in structure.prior.unknowns:
        if unk.fixed:
            continue
        u = df[f"u.{unk.name}"].to_numpy(dtype=float)[sel]
        ws = w[sel]
        x = unk.from_unit(u)
        q = weighted_quantile(x, ws, [0.05, 0.5, 0.95])
        low = float(np.sum(ws[u <= WALL]) / ws.sum())
        high = float(np.sum(ws[u >= 1 - WALL]) / ws.sum())
        wall = "low" if low > 0.5 else "high" if high > 0.5 else None
        out[unk.name] = {"q05": float(q[0]), "q50": float(q[1]), "q95": float(q[2]),
                         "prior": [unk.low, unk.high], "scale": unk.scale,
                         "mass_at_low_wall": low, "mass_at_high_wall": high,
                         "wall": wall}  # fmt: skip
    return out


def _offset(structure: Any, df: Any, sel: NDArray[np.bool_],
            w: NDArray[np.float64]) -> dict[str, Any] | None:  # fmt: skip
    """The pitch estimate's constant offset ``gyro offset x tau`` (rad) of a complementary
    filter without zeroing (:mod:`mwip.hardware.fusion`), its posterior quantiles; ``None``
    where the structure has none (zeroing, or a bias-estimating filter)."""
    from mwip.calibration.posterior import weighted_quantile

    fw = structure.twin.firmware
    if fw.gyro_zeroing or fw.fusion.kind != "complementary" or not sel.any():
        return None
    pr = structure.prior

    def col(name: str) -> NDArray[np.float64]:
        if name in pr.names:
            return np.asarray(pr[name].from_unit(df[f"u.{name}"].to_numpy(dtype=float)[sel]))
        v: Any = structure.twin
        for part in name.split("."):
            v = getattr(v, part)
        return np.full(int(sel.sum()), float(v))

    off = col("imu.gyro_bias") * col("firmware.fusion.tau")
    q = weighted_quantile(np.abs(off), w[sel], [0.05, 0.5, 0.95])
    return {"what": "|gyro offset x fusion tau| (rad): the board's constant pitch-estimate "
                    "offset", "q05": float(q[0]), "q50": float(q[1]), "q95": float(q[2])}


def structure_evidence(name: str, df: Any, ev: Any) -> Any:
    """Revision 7's :class:`~mwip.calibration.compare.StructureEvidence` of one structure's
    rows ``df`` (stages A and B): ``Z`` on stage A alone, what it can meet on every twin
    (module docstring)."""
    return structure_evidence_of(name, df, _facts(df, ev))


def structure_evidence_of(name: str, df: Any, f: Any) -> Any:
    """:func:`structure_evidence` from the rows' fact table ``f`` (any facts: the book's, or
    a robot's own, :mod:`mwip.calibration.robot_evidence`)."""
    from mwip.calibration.compare import evidence_of
    from mwip.calibration.posterior import Facts

    in_a = (df["stage"] == "A").to_numpy()
    se = evidence_of(name, f)
    za = evidence_of(name, Facts(f.names, f.S[in_a], f.log_err[in_a])).evidence
    return replace(se, evidence=za)


def analyse_table(table: Any, structures: dict[str, Any], ev: Any,
                  record: dict[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """The comparison document from the pooled draws ``table`` of every structure (column
    ``structure``): module docstring. ``record``: revisions 1-5's ``posterior.json`` (its
    verdicts are shown beside)."""
    from mwip.calibration.claims import CLAIMS, claim_rows
    from mwip.calibration.compare import bayes_factor, claim_verdict, posterior_probs

    names = [n for n in structures if (table["structure"] == n).any()]
    evs, holds, per, facts_of = [], {}, {}, {}
    for n in names:
        df = table[table["structure"] == n].reset_index(drop=True)
        f = _facts(df, ev)
        facts_of[n] = (df, f)
        se = _evidence_with_d(n, df, f)
        w = se.weights  # stage D's posterior weights; else 1 (the twins found, revision 7)
        evs.append(se)
        cols = {c: df[c].to_numpy(dtype=float) for c in df.columns
                if c not in ("structure", "stage", "weight")}  # fmt: skip
        holds[n] = claim_rows(cols)
        sel = se.conditioned
        ws = w[sel]
        ess = float(ws.sum() ** 2 / np.sum(ws * ws)) if ws.size else 0.0
        stages = {s: int((df["stage"] == s).sum()) for s in ("A", "B", "C", "D")}
        hits = {s: int(np.sum(se.accepted & (df["stage"] == s).to_numpy()))
                for s in ("A", "B", "C", "D")}  # fmt: skip
        per[n] = {**se.to_json(), "title": structures[n].title, "stages": stages,
                  "hits_by_stage": hits, "unknowns": list(structures[n].prior.names),
                  "posterior": bool(stages["D"] and hits["D"]),
                  "conditioned_draws": int(sel.sum()), "conditioned_effective": ess,
                  "facts_met_share": {fn: float(np.sum(ws * f.S[sel, j]) / ws.sum())
                                      if ws.size else None for j, fn in enumerate(f.names)},
                  "marginals": _marginals(structures[n], df, sel, w),
                  "offset": _offset(structures[n], df, sel, w)}  # fmt: skip
    post = posterior_probs(evs)
    bf = {}
    for a in evs:
        for b in evs:
            if a.name < b.name:
                B, lo, hi = bayes_factor(b, a)
                bf[f"{b.name}/{a.name}"] = {"B": B, "lo": lo, "hi": hi}
    claims = []
    old = {}
    if record is not None:
        old = {f"{c['study']}/{c['id']}": c.get("verdict") for c in record.get("claims", [])
               if isinstance(c, dict) and "study" in c}  # fmt: skip
    for c in CLAIMS:
        v = claim_verdict({n: holds[n][c.key] for n in names}, c.needs, evs, ev.decided)
        claims.append({"claim": c.key, "text": c.text, "needs": list(c.needs),
                       "per_structure": {k: {"verdict": vv, "share": sh}
                                         for k, (vv, sh) in v.per_structure.items()},
                       "verdict": v.overall, "p_holds": v.p_holds,
                       "revisions_1_5": old.get(c.key)})  # fmt: skip
    counts = {k: sum(c["verdict"] == k for c in claims)
              for k in ("holds", "fails", "undecided", "not judgeable")}  # fmt: skip
    return {"revision": 9, "structures": per, "posterior_probability": post,
            "bayes_factors": bf, "claims": claims, "claim_counts": counts,
            "member": _member(structures, facts_of, evs, post, ev)}


def _evidence_with_d(name: str, df: Any, f: Any) -> Any:
    """Revision 9's evidence of one structure: where stage D ran, ``Z`` is its importance
    estimate (weights ``w`` of the rows' ``weight`` column) and, where stage D met every
    fact, the posterior is its twins meeting every fact weighted by ``w``; else revision
    7-8's (:func:`structure_evidence_of`). What the structure can meet is read on every
    twin either way."""
    from mwip.calibration.compare import evidence_of
    from mwip.calibration.posterior import Facts

    se = structure_evidence_of(name, df, f)
    d = (df["stage"] == "D").to_numpy()
    if not d.any():
        return se
    wd = df["weight"].to_numpy(dtype=float)[d]
    z = evidence_of(name, Facts(f.names, f.S[d], f.log_err[d]), weights=wd).evidence
    se = replace(se, evidence=z)
    if not np.any(se.accepted & d):
        return se
    w = np.where(d, df["weight"].to_numpy(dtype=float), 0.0)
    return replace(se, weights=w, conditioned=se.accepted & d)


def _member(structures: dict[str, Any], facts_of: dict[str, Any], evs: Sequence[Any],
            post: dict[str, float], ev: Any) -> dict[str, Any] | None:  # fmt: skip
    """Revision 9's default robot: the most probable structure's (ties: the first declared)
    stage-D twin meeting every fact with the largest ABC kernel ``exp(-1/2 sum_k (ln(x_k /
    b_k) / s)^2)``, ``s = ln(tolerance) / 2``, of the calibration numbers (the record's rule,
    :mod:`mwip.calibration.posterior`; ties: the smallest draw index). ``None`` where no
    structure has a probability."""
    if not post or max(post.values()) <= 0:
        return None
    best = max(post, key=lambda n: post[n])  # the first of equals: dict order is declared
    se = next(e for e in evs if e.name == best)
    df, f = facts_of[best]
    sel = np.nonzero(se.conditioned)[0]
    if sel.size == 0:
        return None
    s = ev.log_tolerance / 2.0
    logk = -0.5 * np.sum((f.log_err[sel] / s) ** 2, axis=1)
    order = np.lexsort((df["sample"].to_numpy()[sel], -logk))
    i = int(sel[order[0]])
    st = structures[best]
    u = np.array([[float(df[f"u.{n}"].iloc[i]) for n in st.prior.names]])
    x = st.from_unit(u)[0]
    keys = [n.key for n in ev.numbers]
    return {"structure": best, "stage": str(df["stage"].iloc[i]),
            "sample": int(df["sample"].iloc[i]), "log_kernel": float(logk[order[0]]),
            "values": {n: float(v) for n, v in zip(st.prior.names, x, strict=True)},
            "numbers": {k: float(df[k].iloc[i]) for k in keys},
            "book": {n.key: float(n.book) for n in ev.numbers},
            "firmware": {"gyro_zeroing": bool(st.twin.firmware.gyro_zeroing),
                         "fusion": str(st.twin.firmware.fusion.kind)}}  # fmt: skip


def member_robot_text(doc: dict[str, Any], structures: dict[str, Any]) -> str:
    """The robot file of revision 9's default robot (``doc["member"]``, :func:`_member`): the
    book's body and design model, its structure's twin (firmware switches, prior) with the
    member's values, the sources and the notes saying where it comes from."""
    from mwip.robot import Robot, robot_to_toml

    m = doc["member"]
    n = m["structure"]
    s = doc["structures"][n]
    st = structures[n]
    lo, hi = s["evidence_95"]
    others = [f"{k} {v:.3g}" for k, v in doc["posterior_probability"].items() if k != n]
    nums = "; ".join(f"{k} {m['numbers'][k]:.4g} (book {m['book'][k]:.4g})"
                     for k in m["numbers"])  # fmt: skip
    notes = (
        "The book's robot: Tables 6.1 (body) and 6.2 (design model), their damping read as D "
        "r^2 (SPEC.md section 2), and the most probable member of the most probable twin "
        "structure of the book calibration, revision 9 (`mwip twin calibrate book`; "
        "mwip/calibration/book-structures.toml, docs/book_calibration/structures.md).\n"
        f"Structure {n}: {st.title}. Its probability given the {len(s['facts_met_share'])} "
        "calibration facts: "
        f"{doc['posterior_probability'][n]:.3g} (the others: {', '.join(others)}); Z = "
        f"P(its prior meets every fact) = {s['evidence']:.3g} (95 %: {lo:.3g}-{hi:.3g}), by "
        f"importance sampling ({s['stages']['D']:,} twins drawn around the "
        f"{s['found'] - s['hits_by_stage']['D']:,} found first, {s['hits_by_stage']['D']:,} of "
        f"them meeting every fact, whose weights count as about "
        f"{s['conditioned_effective']:.0f} equally weighted twins).\n"
        f"This member: draw {m['sample']}, the largest ABC kernel of the calibration numbers "
        f"among them (ln kernel {m['log_kernel']:.3g}): {nums}.")
    src = (f"unknown (prior); identified: most probable member of structure {n}, the most "
           "probable of the book calibration (revision 9; robot.notes)")
    fw = st.twin.firmware
    switches = {"firmware.gyro_zeroing": f"assumed: {'' if fw.gyro_zeroing else 'no '}power-on "
                f"gyro zeroing, as structure {n} declares, the most probable of the book "
                "calibration (revision 9; robot.notes)",
                "firmware.fusion.kind": f"assumed: a {fw.fusion.kind} fusion, as structure {n} "
                "declares, the most probable of the book calibration (revision 9; "
                "robot.notes)"}  # fmt: skip
    twin = st.twin.with_values(m["values"])
    robot = Robot(twin=twin, name="book", notes=notes,
                  provenance=tuple((k, src) for k in m["values"]) + tuple(switches.items()))
    return robot_to_toml(robot)


def _record() -> dict[str, Any] | None:
    import json

    p = Path(__file__).resolve().parents[3] / "docs" / "book_calibration" / "posterior.json"
    if not p.exists():
        return None
    doc: dict[str, Any] = json.loads(p.read_text())
    return doc


def write_result(out: Path, table: Any, structures: dict[str, Any], ev: Any) -> dict[str, Any]:
    """``structures.json``, ``structures.md`` and ``structures.png`` in ``out`` from ``table``
    (the replay file's rows): every number and the figure of the result come from here."""
    from mwip.calibration.comparison_figure import figure
    from mwip.calibration.comparison_report import report_md
    from mwip.io import json_text, write_text_atomic

    doc = analyse_table(table, structures, ev, _record())
    doc["declaration_sha256"] = _declaration_hash()
    write_text_atomic(out / RESULT_FILE, json_text(doc))
    write_text_atomic(out / "structures.md", report_md(doc))
    figure(doc, out / "structures.png")
    from mwip.calibration.default_status import status_document
    from mwip.calibration.structures import load_importance

    plan = load_importance()
    status = status_document(doc, table, structures, ev, 0 if plan is None else plan.seed)
    if status is not None:
        write_text_atomic(out / ROBOT_FILE, member_robot_text(doc, structures))
        write_text_atomic(out / STATUS_FILE, json_text(status))
    else:  # no default robot of this result: a stale one of an earlier result goes
        for name in (ROBOT_FILE, STATUS_FILE):
            if (out / name).exists():
                (out / name).unlink()
    return doc


def _declaration_hash() -> str:
    from mwip.calibration.structures import STRUCTURES_FILE

    return hashlib.sha256(STRUCTURES_FILE.read_bytes()).hexdigest()


def run_comparison(out: Path, *, evidence: Path | None = None,
                   names: Sequence[str] | None = None, jobs: int = 1,
                   duration: float = 0.0, prior_draws: int | None = None,
                   kernel_draws: int | None = None, replay: Path | None = None,
                   directed_draws: int | None = None, importance_draws: int | None = None,
                   note: Callable[[str], None] | None = None) -> dict[str, Any]:  # fmt: skip
    """Sample (or resume) every named structure into ``out`` and write the comparison; with
    ``replay`` read the per-draw table from that file instead (no run). ``directed_draws``:
    stage C's twins per generation (default the declaration's; 0: no stage C);
    ``importance_draws``: stage D's twins (default the declaration's; 0: no stage D)."""
    import pandas as pd

    from mwip.calibration.evidence import EVIDENCE_FILE, load_evidence
    from mwip.calibration.structures import (
        load_directed,
        load_importance,
        load_plan,
        load_structures,
    )
    from mwip.io import write_parquet_atomic

    ev = load_evidence(EVIDENCE_FILE if evidence is None else Path(evidence))
    structures = load_structures()
    pick = list(structures) if not names else list(names)
    for n in pick:
        if n not in structures:
            raise ValueError(f"--structures: unknown structure {n!r}; allowed: "
                             f"{', '.join(structures)}")  # fmt: skip
    chosen = {n: structures[n] for n in pick}
    if replay is not None:
        table = pd.read_parquet(replay)
        table = table[table["structure"].isin(pick)].reset_index(drop=True)
    else:
        plan = load_plan()
        directed = load_directed()
        if directed is not None and directed_draws is not None:
            directed = replace(directed, per_generation=int(directed_draws),
                               generations=directed.generations if directed_draws else 0)
        importance = load_importance()
        if importance is not None and importance_draws is not None:
            importance = replace(importance, draws=int(importance_draws))
        parts = []
        for n, s in chosen.items():
            df = sample_structure(s, plan, out / "draws" / n, ev, jobs=jobs, duration=duration,
                                  prior_draws=prior_draws, kernel_draws=kernel_draws,
                                  note=note)  # fmt: skip
            c = directed_stage(s, df, directed, out / "draws" / n, ev, block=plan.block,
                               jobs=jobs, duration=duration, note=note)  # fmt: skip
            df = pd.concat([df, c], ignore_index=True)
            d = importance_stage(s, df, importance, out / "draws" / n, ev, block=plan.block,
                                 jobs=jobs, duration=duration, note=note)  # fmt: skip
            df = pd.concat([df, d], ignore_index=True)
            df.insert(0, "structure", n)
            parts.append(df)
        table = pd.concat(parts, ignore_index=True)
        # compact and lossless (the shipped file's limit is 20 MB): zstd over the floats'
        # bytes split by significance
        floats = [c for c in table.columns if table[c].dtype == np.float64]
        write_parquet_atomic(out / DRAWS_FILE, table, compression="zstd", compression_level=9,
                             use_dictionary=["structure", "stage"],
                             use_byte_stream_split=floats)  # fmt: skip
        table = pd.read_parquet(out / DRAWS_FILE)
    return write_result(out, table, chosen, ev)
