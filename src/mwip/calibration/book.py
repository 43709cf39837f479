"""``mwip twin calibrate book --record``: the book's robot conditioned on the book's evidence.

1. Draw the twin's prior (:mod:`mwip.hardware.prior`; ``samples`` draws, ``seed``) and run
   every Chapter 6 run on every draw: a campaign of ``kind = "calibration"`` (Dask, chunked,
   resumable, deterministic: :mod:`mwip.calibration.sample`) in ``OUT/prior-draws``.
2. Condition on the calibration evidence declared in ``book-evidence.toml`` before any fit
   (:mod:`mwip.calibration.posterior`): facts, acceptance, the smallest conflicting sets and
   the largest consistent subset if the facts conflict, marginals, the most probable member.
3. Judge the held-out evidence on every consistent twin (:mod:`mwip.calibration.claims`) and
   the held-out numbers of Tables 6.4-6.8 against the posterior's predictive range.

The declaration's revisions add samplers of the same posterior: stage 2's box draws
(:mod:`mwip.calibration.proposal`), stage 3's Markov chains (:mod:`mwip.calibration.chains`)
and stages 4-5's mixture and envelope draws (:mod:`mwip.calibration.pooled`, revisions 3-5:
conditioned on the largest consistent subset over every twin stages 1-3 evaluated, pooled with
stages 1-2 by exact importance weights: the posterior of record). Its words and figure are
:mod:`mwip.calibration.report`.

Outputs in ``OUT``: ``posterior.json`` (everything), ``posterior.md`` (the same in words),
``robot.toml`` (the most probable member as a robot file, with its provenance), ``marginals.png``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mwip.calibration.evidence import EVIDENCE_FILE, Evidence, load_evidence
from mwip.calibration.pooled import (
    STAGE4_OFFSET,
    beyond_cols,
    mixture_pool,
    mixture_stage,
    pooled_record,
    resampled,
    table_cols,
)
from mwip.calibration.report import figure, provenance, report_text

__all__ = ["BookCalibration", "calibrate_book", "analyse", "POSTERIOR_FILE"]

POSTERIOR_FILE = "posterior.json"

@dataclass(frozen=True)
class BookCalibration:
    """The result: the document written to ``posterior.json`` and the most probable twin."""

    doc: dict[str, Any]
    twin: Any
    accepted: np.ndarray  # (N,) the draws consistent with the facts conditioned on


def _evidence_hash() -> str:
    return hashlib.sha256(EVIDENCE_FILE.read_bytes()).hexdigest()


def _chain_cols(chains: Any, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The chains' kept states as columns, C K rows chain by chain."""
    C, K, _ = chains.x.shape
    cols = {k: np.asarray(v, dtype=float).reshape(C * K) for k, v in chains.cols.items()}
    for j, n in enumerate(names):
        cols[f"param.{n}"] = chains.x[:, :, j].reshape(C * K).copy()
    return cols


#: Posterior members written to ``posterior.json`` per chain (its kept states, evenly spaced,
#: the last one included): what ``mwip bench``'s ``posterior`` level draws from.
MEMBERS_PER_CHAIN = 4


def _members(chains: Any, names: tuple[str, ...]) -> list[dict[str, float]]:
    """A thinned set of the chains' kept states as unknown values (chain by chain)."""
    C, K, _ = chains.x.shape
    picks = np.unique(np.linspace(K - 1, 0, MEMBERS_PER_CHAIN).round().astype(int))[::-1]
    return [{n: float(chains.x[c, k, j]) for j, n in enumerate(names)}
            for c in range(C) for k in sorted(picks)]  # fmt: skip


def _beyond(chains: Any, ev: Evidence, used: tuple[str, ...]) -> dict[str, Any]:
    """Whether a twin the chains evaluated met more than the conditioned facts: the largest
    such set's extra facts and how many proposals met it (it does not change the conditioning,
    fixed by stages 1-2 before the chains ran)."""
    props = chains.proposals
    if props is None or len(props) == 0:
        return {"proposals": 0, "extra": [], "count": 0}
    cols = {c: props[c].to_numpy(dtype=float) for c in props.columns
            if c not in ("chain", "generation", "inside", "moved")}  # fmt: skip
    return beyond_cols(cols, ev, used)


def _wider(pool: dict[str, np.ndarray], chains: Any, chain: dict[str, np.ndarray],
           verdicts: dict[str, np.ndarray], ev: Evidence,
           used: tuple[str, ...]) -> dict[str, Any] | None:  # fmt: skip
    """The original rule (the largest consistent subset) over *every* twin evaluated, the
    pool and the chains' proposals alike; ``None`` when it is the conditioned set. Then the
    kept chain states that also meet the extra facts are a sample of the posterior on that
    larger set (a sample of ``pi`` restricted to a subset is one of ``pi`` conditioned on it),
    as converged as the chains are: each held-out claim's fraction on them (``verdicts``: each
    claim's per-state verdict over ``chain``), by the declared verdict rule. A secondary
    result: the conditioning of record stays ``used``."""
    from mwip.calibration.posterior import consistent_subset, facts
    from mwip.calibration.runs import run_names

    names = run_names()
    props = chains.proposals
    keys = [k for k in pool if not k.startswith("param.") and k != "weight"]
    both = {k: np.concatenate([pool[k], props[k].to_numpy(dtype=float)]) for k in keys}
    f = facts(both, names, ev)
    mask, _ = consistent_subset(f)
    wide = tuple(n for n, m in zip(f.names, mask, strict=True) if m)
    if set(wide) <= set(used):
        return None
    fc = facts(chain, names, ev)
    sel = np.all(fc.S[:, [fc.names.index(n) for n in wide]], axis=1)
    C, K, _ = chains.x.shape
    out: dict[str, Any] = {
        "used": list(wide), "extra": [n for n in wide if n not in used],
        "twins_evaluated": int(f.S.shape[0]),
        "twins_meeting": int(np.all(f.S[:, mask], axis=1).sum()),
        "kept_states": int(sel.sum()), "of_kept": C * K,
        "chains": int(np.unique(np.nonzero(sel.reshape(C, K))[0]).size), "claims": [],
    }
    if sel.any():
        for key, v in verdicts.items():
            frac = float(np.mean(v[sel]))
            verdict = ("holds" if frac >= ev.decided else "fails" if frac <= 1 - ev.decided
                       else "undecided")  # fmt: skip
            out["claims"].append({"claim": key, "fraction": frac, "verdict": verdict})
    return out


def _chain_diagnostics(
    chains: Any, verdicts: dict[str, np.ndarray], names: tuple[str, ...]
) -> tuple[dict[str, Any], dict[str, float]]:
    """The sampler's record (acceptance, final scale, evaluations, each unknown's split
    R-hat and ESS) and each held-out claim's ESS (a claim constant over the sample: the
    smallest ESS of the unknowns)."""
    from mwip.calibration.diagnostics import ess, split_rhat

    C, K, _ = chains.x.shape
    p_ess, p_rhat = {}, {}
    for j, n in enumerate(names):
        x = chains.x[:, :, j]
        if np.ptp(x) > 0:
            p_ess[n], p_rhat[n] = ess(x), split_rhat(x)
    floor = min(p_ess.values()) if p_ess else float(C * K)
    c_ess = {}
    for key, v in verdicts.items():
        e = ess(np.asarray(v, dtype=float).reshape(C, K))
        c_ess[key] = floor if not np.isfinite(e) else min(e, float(C * K))
    record = {"chains": C, "kept": K, "burn": chains.burn, "evaluations": chains.evaluations,
              "acceptance": chains.acceptance(), "acceptance_burn_in":
              float(chains.moved[:, : chains.burn].mean()), "scale": chains.scale,
              "ess": p_ess, "rhat": p_rhat, "ess_min": floor,
              "rhat_max": max(p_rhat.values()) if p_rhat else None}  # fmt: skip
    limit = chains.plan.converged if chains.plan is not None else 1.1
    record["converged_below"] = limit
    record["converged"] = bool(record["rhat_max"] is not None and record["rhat_max"] < limit)
    return record, c_ess


def analyse(table: Any, ev: Evidence, *, prior: Any = None, prior_draws: Any = None,
            chains: Any = None, mixture: Any = None) -> BookCalibration:  # fmt: skip
    """Condition the draws ``table`` (the prior draws of the calibration campaign, pooled
    with stage 2's box draws and their ``weight`` column, :mod:`mwip.calibration.proposal`)
    on the evidence ``ev`` and judge the held-out claims and numbers. ``prior_draws``: the
    plain prior draws (each run's standing rate in the prior; default ``table``).

    ``mixture``: stages 4-5's :class:`~mwip.calibration.pooled.MixtureResult` (revisions
    3-5), whose draws ``table`` then also holds (:func:`mixture_pool`: balance-heuristic
    ``weight`` over stages 1, 2, 4 and 5, stages 1-2's own in ``weight12``): the posterior
    of record is the weighted pool conditioned on ``mixture.used``, its most probable member
    the default twin; the chains (if given) are reported as stage 3's record only.

    ``chains`` without ``mixture``: stage 3's :class:`~mwip.calibration.chains.ChainResult`,
    which samples the posterior ``table`` conditioned (the same facts): the marginals, claims
    and numbers are then the chains' kept states, each interval at its effective size, and the
    default twin stays the pool's most probable member (every chain state meets the same
    facts, so its kernel ties with it or is smaller; the declared tie-break is the first in
    draw order)."""
    from mwip.calibration.claims import claim_rows, judge
    from mwip.calibration.posterior import condition, facts, weighted_quantile
    from mwip.calibration.runs import PUBLISHED, run_names
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR
    from mwip.hardware.twin import Twin

    pr = PRIOR if prior is None else prior
    pool = table_cols(table)
    bounds = {n: (float(lo), float(hi)) for n, (lo, hi) in zip(pr.names, pr.bounds, strict=True)}
    names = run_names()
    sampler: dict[str, Any] | None = None
    c_ess: dict[str, float] | None = None
    if mixture is not None:
        w12 = pool.pop("weight12")
        s12 = table["sample"].to_numpy() < STAGE4_OFFSET  # stages 1-2
        p12 = {k: v[s12] for k, v in pool.items()}
        stage12 = condition(facts(p12, names, ev), {n: p12[f"param.{n}"] for n in pr.names},
                            bounds, ev, weights=w12[s12])  # fmt: skip
        cols = pool
        post = condition(facts(pool, names, ev), {n: pool[f"param.{n}"] for n in pr.names},
                         bounds, ev, weights=pool["weight"], used=mixture.used,
                         conflicts=mixture.conflicts)  # fmt: skip
        accepted, post_w, map_index = post.accepted, post.weights, post.map_index
        verdicts = claim_rows(cols)
        sampler = pooled_record(mixture, post, table["sample"].to_numpy(), pool, ev)
        summary = post.summary()
        summary.update(sampler=sampler, stage12=stage12.summary())
        if chains is not None:
            summary["stage3"] = _chain_diagnostics(chains, {}, tuple(pr.names))[0]
    else:
        f = facts(pool, names, ev)
        stage12 = condition(f, {n: pool[f"param.{n}"] for n in pr.names}, bounds, ev,
                            weights=pool.get("weight"))  # fmt: skip
    if mixture is None and chains is not None and stage12.map_index >= 0:
        chain = _chain_cols(chains, tuple(pr.names))
        post = condition(facts(chain, names, ev), {n: chain[f"param.{n}"] for n in pr.names},
                         bounds, ev, used=stage12.used, conflicts=stage12.conflicts)  # fmt: skip
        if not np.all(post.accepted):
            raise ValueError("a chain state does not meet the conditioned facts")
        n_ch = len(post.accepted)
        # the pool's most probable member as one more row: not a member, it carries the
        # default twin's verdicts and numbers
        cols = {k: np.append(v, pool[k][stage12.map_index]) for k, v in chain.items()}
        accepted = np.arange(n_ch + 1) < n_ch
        post_w = accepted.astype(float)
        map_index = n_ch
        verdicts = claim_rows(cols)
        members_v = {k: v[:n_ch] for k, v in verdicts.items()}
        sampler, c_ess = _chain_diagnostics(chains, members_v, tuple(pr.names))
        sampler["beyond"] = _beyond(chains, ev, stage12.used)
        sampler["wider"] = _wider(pool, chains, chain, members_v, ev, stage12.used)
        summary = post.summary()
        summary.update(n_prior=int(len(table)), size=n_ch, map_index=stage12.map_index,
                       effective_size=sampler["ess_min"], sampler=sampler,
                       stage12=stage12.summary())  # fmt: skip
    elif mixture is None:
        cols, post = pool, stage12
        accepted, post_w, map_index = post.accepted, post.weights, post.map_index
        summary = post.summary()
        verdicts = claim_rows(cols)
    params = {n: cols[f"param.{n}"] for n in pr.names}
    claims = judge(verdicts, accepted, params, map_index, ev.decided, weights=post_w,
                   ess=c_ess)  # fmt: skip
    calib = {n.key for n in ev.numbers}
    numbers = []
    lo_q, hi_q = (1 - ev.interval) / 2, 1 - (1 - ev.interval) / 2
    for key, book in PUBLISHED.items():
        x = cols[key][accepted] if key in cols else np.zeros(0)
        wx = post_w[accepted][np.isfinite(x)] if key in cols else np.zeros(0)
        x = x[np.isfinite(x)]
        entry: dict[str, Any] = {"key": key, "book": book, "role": "calibration" if key in calib
                                 else "held-out", "n": int(x.size)}  # fmt: skip
        if x.size:
            lo, med, hi = (float(v) for v in weighted_quantile(x, wx, [lo_q, 0.5, hi_q]))
            entry.update(low=lo, median=med, high=hi, inside=bool(lo <= book <= hi))
        if map_index >= 0 and key in cols:
            entry["default_twin"] = float(cols[key][map_index])
        numbers.append(entry)
    map_standing = ({r: bool(cols[f"{r}.stands"][map_index] == 1.0) for r in names}
                    if map_index >= 0 else {})  # fmt: skip
    pcols = pool if prior_draws is None else table_cols(prior_draws)
    standing = {r: float(np.mean(pcols[f"{r}.stands"])) for r in names}
    map_values: dict[str, float] = {}
    twin = None
    if map_index >= 0:
        map_values = {n: float(params[n][map_index]) for n in pr.names}
        twin = Twin().with_values(map_values)
    counts = {v: sum(1 for c in claims if c["verdict"] == v)
              for v in ("holds", "fails", "undecided", "no posterior")}  # fmt: skip
    doc = {
        "title": ev.title,
        "evidence_file": EVIDENCE_FILE.name,
        "evidence_sha256": _evidence_hash(),
        "signals": "measured: the board's fused pitch estimate and the encoder wheel speeds "
                   "(y_meas), not the true state",
        "acceptance": {"tolerance": ev.tolerance, "rule": "every run stands and |ln(x/book)| "
                       f"<= ln({ev.tolerance:g}) for every calibration number",
                       "kernel_scale": ev.kernel_scale},  # fmt: skip
        "prior": {"names": list(pr.names), "bounds": [list(map(float, b)) for b in pr.bounds]},
        "standing_in_prior": standing,
        "calibration_numbers": [{"key": n.key, "book": n.book, "source": n.source,
                                 "map": (float(cols[n.key][map_index])
                                         if map_index >= 0 else None)}
                                for n in ev.numbers],  # fmt: skip
        "posterior": summary,
        "map_values": map_values,
        "map_standing": map_standing,
        "claims": claims,
        "claim_counts": counts,
        "numbers": numbers,
        "evaluated": int(len(table)),
    }
    if mixture is not None:
        doc["members"] = resampled(params, post_w, accepted, mixture.plan.seed)
    elif chains is not None and sampler is not None:
        doc["members"] = _members(chains, tuple(pr.names))
    return BookCalibration(doc, twin, accepted if mixture is not None else stage12.accepted)


def calibrate_book(
    out: Path,
    *,
    samples: int | None = None,
    seed: int | None = None,
    block: int | None = None,
    jobs: int | None = 1,
    duration: float = 0.0,
    progress: Callable[[int, int, float], None] | None = None,
    proposal: Any = True,
    proposal_draws: int | None = None,
    chains: Any = True,
    chain_steps: int | None = None,
    mixture: Any = True,
    mixture_draws: int | None = None,
    envelope: Any = True,
    envelope_draws: int | None = None,
    note: Callable[[str], None] | None = None,
) -> BookCalibration:
    """Run (or resume) the book calibration into ``out``; returns the result and writes
    ``posterior.json``, ``posterior.md``, ``robot.toml``, ``marginals.png`` (atomically).
    ``samples``, ``seed``, ``block`` default to the declaration's; ``duration`` > 0 caps every
    run (a smoke test: its verdicts are not the book's experiments). ``proposal``: stage 2's
    box sample (:class:`mwip.calibration.proposal.BoxProposal`; ``True``: the declaration's,
    ``None``: none), ``proposal_draws`` its size (a smoke test); ``chains``: stage 3's plan
    (:class:`mwip.calibration.chains.ChainPlan`; ``True``: the declaration's, ``None``: none),
    ``chain_steps`` its generations with the burn-in scaled alike (a smoke test);
    ``mixture``: stage 4's plan (:class:`mwip.calibration.mixture.MixturePlan`; ``True``: the
    declaration's, ``None``: none), ``mixture_draws`` its size (a smoke test); ``envelope``,
    ``envelope_draws``: stage 5's alike (:class:`mwip.calibration.mixture.EnvelopePlan`; run
    only with stage 4; ``envelope_draws`` also turns revision 5's extension off); ``note``
    receives one line per stage-2 or stage-4 block and per stage-3 generation."""
    import math

    import pandas as pd

    from mwip.calibration.sample import calibration_campaign
    from mwip.campaign.execute import run_campaign

    if (isinstance(duration, bool) or not isinstance(duration, int | float)
            or not (math.isfinite(duration) and 0.0 <= duration <= 15.0)):  # fmt: skip
        raise ValueError(f"'duration' must be in [0, 15] s (0: the studies' own), got "
                         f"{duration!r}")  # fmt: skip
    from mwip.io import write_json_atomic, write_text_atomic

    ev = load_evidence()
    camp = calibration_campaign(samples or ev.samples, ev.seed if seed is None else seed,
                                block or ev.block, duration)  # fmt: skip
    kw: dict[str, Any] = {"jobs": jobs}
    if progress is not None:
        kw["progress"] = progress
    summary = run_campaign(camp, out / "prior-draws", **kw)
    if summary.status == "interrupted":
        raise KeyboardInterrupt
    table = pd.read_parquet(out / "prior-draws" / "results.parquet")
    box = (ev.proposal if proposal is True else proposal) if proposal is not None else None
    if box is not None and proposal_draws is not None:
        box = replace(box, draws=int(proposal_draws))
    pop = table
    if box is not None:
        pop = box_sample(table, ev, box, out / "proposal", jobs=jobs or 1, duration=duration,
                         note=note)  # fmt: skip
    plan = (ev.chains if chains is True else chains) if chains is not None else None
    if plan is not None and chain_steps is not None:
        burn = max(2, int(round(plan.burn * chain_steps / plan.steps)))
        plan = replace(plan, steps=max(int(chain_steps), burn + 4), burn=burn)
    ch = (chain_stage(pop, ev, plan, out / "chains", duration=duration, note=note)
          if plan is not None else None)  # fmt: skip
    mplan = (ev.mixture if mixture is True else mixture) if mixture is not None else None
    if mplan is not None and mixture_draws is not None:
        mplan = replace(mplan, draws=int(mixture_draws))
    eplan = (ev.envelope if envelope is True else envelope) if envelope is not None else None
    if eplan is not None and envelope_draws is not None:  # a smoke test: no extension
        eplan = replace(eplan, draws=int(envelope_draws), max_draws=None, effective=None)
    mix = (mixture_stage(pop, ch, ev, mplan, out / "mixture", duration=duration,
                         envelope=eplan, envelope_store=out / "envelope", box=box, note=note)
           if mplan is not None else None)  # fmt: skip
    if mix is not None:
        pop = mixture_pool(table, pop, box, mix)
    res = analyse(pop, ev, prior_draws=table, chains=ch, mixture=mix)
    res.doc["samples"] = camp.samples
    res.doc["seed"] = camp.seed
    res.doc["duration_cap"] = duration or None
    write_json_atomic(out / POSTERIOR_FILE, res.doc)
    write_text_atomic(out / "posterior.md", report_text(res.doc))
    if res.twin is not None:
        write_text_atomic(out / "robot.toml", map_robot_text(res.doc, res.twin))
    names = res.doc["prior"]["names"]
    if mix is None and ch is not None and "sampler" in res.doc["posterior"]:
        post = {n: ch.x[:, :, j].reshape(-1) for j, n in enumerate(names)}
        wk = np.ones(ch.x.shape[0] * ch.x.shape[1])
    else:
        ok = res.accepted
        w = pop["weight"].to_numpy(dtype=float) if "weight" in pop else np.ones(len(ok))
        post = {n: pop[f"param.{n}"].to_numpy(dtype=float)[ok] for n in names}
        wk = w[ok]
    figure(table, res.doc, post, wk, out / "marginals.png")
    return res


def map_robot_text(doc: dict[str, Any], twin: Any) -> str:
    """The robot file of the posterior's most probable twin: the book's body and design
    model, the twin, its provenance as the robot's notes."""
    from mwip.robot import Robot, robot_to_toml

    notes = "\n".join(line[2:] if line.startswith("# ") else line.lstrip("#")
                      for line in provenance(doc).splitlines())  # fmt: skip
    src = "unknown (prior); identified: most probable twin of the book calibration (robot.notes)"
    robot = Robot(twin=twin, name="book", notes=notes,
                  provenance=tuple((n, src) for n in doc["prior"]["names"]))  # fmt: skip
    return robot_to_toml(robot)


def box_sample(table: Any, ev: Evidence, box: Any, store: Path, *, jobs: int = 1,
               duration: float = 0.0, note: Callable[[str], None] | None = None) -> Any:
    """Stage 2 (:mod:`mwip.calibration.proposal`): the box draws, pooled with the prior draws
    ``table`` under the balance-heuristic weights (column ``weight``)."""
    import pandas as pd

    from mwip.calibration.proposal import inside, mis_weights, sample_box
    from mwip.calibration.sample import evaluate
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)

    def run(values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return evaluate(values, jobs=jobs, block=ev.block, duration=duration)

    extra = sample_box(box, names, bounds, run, block=ev.block, store=store, note=note)
    pool = pd.concat([table, extra], ignore_index=True)
    x = pool[[f"param.{n}" for n in names]].to_numpy(dtype=float)
    pool["weight"] = mis_weights(inside(x, box.ranges(names, bounds)), len(table), len(extra),
                                 box.fraction(names, bounds))  # fmt: skip
    return pool


def chain_stage(pool: Any, ev: Evidence, plan: Any, store: Path, *, duration: float = 0.0,
                note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Stage 3 (:mod:`mwip.calibration.chains`): the chains of ``plan`` from the consistent
    twins of the pool ``pool`` (stages 1-2), conditioned on the facts the pool conditioned
    on; ``None`` when no twin of the pool is consistent (nothing to start from). Each
    generation is one batch of twins in this process (the compiled twin loop spreads a batch
    over the cores)."""
    from mwip.calibration.chains import run_chains
    from mwip.calibration.posterior import condition, facts
    from mwip.calibration.runs import run_names
    from mwip.calibration.sample import evaluate
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    cols = table_cols(pool)
    runs = run_names()
    f = facts(cols, runs, ev)
    post = condition(f, {n: cols[f"param.{n}"] for n in names},
                     {n: (float(lo), float(hi)) for n, (lo, hi) in zip(names, bounds, strict=True)},
                     ev, weights=cols.get("weight"))  # fmt: skip
    if not post.accepted.any():
        return None
    mask = np.array([n in set(post.used) for n in f.names], dtype=bool)
    idx = np.nonzero(post.accepted)[0]
    keys = [k for k in cols if not k.startswith("param.") and k != "weight"]
    start = np.column_stack([cols[f"param.{n}"][idx] for n in names])
    start_cols = {k: cols[k][idx] for k in keys}

    def consistent(c: Any) -> np.ndarray:
        return np.all(facts(dict(c), runs, ev).S[:, mask], axis=1)

    def run(values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return evaluate(values, jobs=1, block=10**6, duration=duration)

    return run_chains(plan, names, bounds, start, start_cols, run, consistent, store=store,
                      note=note)  # fmt: skip

