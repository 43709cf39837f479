"""``mwip twin fit --evidence book``: the book's robot conditioned on the book's evidence.

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
and stage 4's mixture draws (:mod:`mwip.calibration.mixture`, revision 3: conditioned on the
largest consistent subset over every twin stages 1-3 evaluated, the posterior of record).

Outputs in ``OUT``: ``posterior.json`` (everything), ``posterior.md`` (the same in words),
``twin.toml`` (the most probable member as a twin file, with its provenance), ``marginals.png``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mwip.calibration.evidence import EVIDENCE_FILE, Evidence, load_evidence

__all__ = ["BookCalibration", "calibrate_book", "analyse", "POSTERIOR_FILE"]

POSTERIOR_FILE = "posterior.json"

#: ``sample`` of stage 4's draw ``s`` is ``STAGE4_OFFSET + s`` (stage 2's: 10^9 + s; stage 1's: s).
STAGE4_OFFSET = 2 * 10**9
#: ... and of stage 5's, ``STAGE5_OFFSET + s``.
STAGE5_OFFSET = 3 * 10**9

#: Posterior members written to ``posterior.json`` by stage 4 (systematic resampling).
MEMBERS = 256


@dataclass(frozen=True)
class BookCalibration:
    """The result: the document written to ``posterior.json`` and the most probable twin."""

    doc: dict[str, Any]
    twin: Any
    accepted: np.ndarray  # (N,) the draws consistent with the facts conditioned on


@dataclass(frozen=True)
class MixtureResult:
    """Stage 4: the facts conditioned on (``used``, the largest consistent subset over the
    ``evaluated`` twins of stages 1-3, with its smallest ``conflicts``), the ``seeds`` twins
    meeting them, the fitted ``mixture`` and its draws ``table`` (a DataFrame)."""

    plan: Any  # mwip.calibration.mixture.MixturePlan
    used: tuple[str, ...]
    conflicts: tuple[tuple[str, ...], ...]
    seeds: int
    evaluated: int
    mixture: Any  # mwip.calibration.mixture.KernelMixture
    table: Any
    envelope_plan: Any = None  # stage 5 (revision 4): mwip.calibration.mixture.EnvelopePlan
    envelope: Any = None  # its one-box KernelMixture
    envelope_table: Any = None  # its draws
    envelope_ess: tuple[float, ...] = ()  # revision 5: the pooled effective size per block

    def stages(self) -> list[tuple[str, Any, Any]]:
        """``(name, density, draws)`` of stage 4 and (if run) stage 5."""
        out = [("mixture", self.mixture, self.table)]
        if self.envelope is not None:
            out.append(("envelope", self.envelope, self.envelope_table))
        return out


def _evidence_hash() -> str:
    return hashlib.sha256(EVIDENCE_FILE.read_bytes()).hexdigest()


def _cols(table: Any) -> dict[str, np.ndarray]:
    return {c: table[c].to_numpy(dtype=float) for c in table.columns
            if c not in ("evidence", "sample")}  # fmt: skip


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
    return _beyond_cols(cols, ev, used)


def _beyond_cols(cols: dict[str, np.ndarray], ev: Evidence,
                 used: tuple[str, ...]) -> dict[str, Any]:  # fmt: skip
    """Of the twins ``cols`` that meet the facts ``used``, the largest set of further facts
    some meet (``extra``) and how many meet exactly it (``count``); ``proposals``: the twins."""
    from mwip.calibration.posterior import facts
    from mwip.calibration.runs import run_names

    f = facts(cols, run_names(), ev)
    mask = np.array([n in set(used) for n in f.names], dtype=bool)
    meets = np.all(f.S[:, mask], axis=1)
    extra = f.S[:, ~mask] & meets[:, None]
    k = extra.sum(axis=1)
    best = int(k.max()) if k.size else 0
    if best == 0:
        return {"proposals": int(f.S.shape[0]), "extra": [], "count": 0}
    rows = extra[k == best]
    first = rows[0]
    names = [n for n, m in zip(np.asarray(f.names)[~mask], first, strict=True) if m]
    return {"proposals": int(f.S.shape[0]), "extra": names,
            "count": int(np.all(rows == first, axis=1).sum())}


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


def _mixture_record(mix: MixtureResult, post: Any, sample: np.ndarray,
                    pool: dict[str, np.ndarray], ev: Evidence) -> dict[str, Any]:  # fmt: skip
    """Stage 4's record: its plan, the seed set, hits, the weighted posterior's Kish
    effective size against the declared threshold, each stage's share of the posterior
    weight, the largest single weight's share, and whether a stage-4 draw met more facts."""
    acc, w = post.accepted, post.weights
    st = np.select([sample >= STAGE5_OFFSET, sample >= STAGE4_OFFSET, sample >= 10**9],
                   [3, 2, 1], 0)  # fmt: skip
    labels = ("prior", "box", "mixture", "envelope")
    total = float(w[acc].sum()) if acc.any() else 0.0
    share = {name: (float(w[acc & (st == k)].sum()) / total if total > 0 else 0.0)
             for k, name in enumerate(labels)}  # fmt: skip
    hits = {name: int((acc & (st == k)).sum()) for k, name in enumerate(labels)}
    four = st == 2
    rec = {
        "kind": "mixture", "draws": mix.plan.draws, "seed": mix.plan.seed,
        "factors": list(mix.plan.factors), "components": int(len(mix.mixture.pi)),
        "seeds": mix.seeds, "evaluated_before": mix.evaluated, "hits": hits,
        "hit_rate": hits["mixture"] / max(int(four.sum()), 1),
        "effective_size": post.ess, "effective_needed": mix.plan.effective,
        "precise": bool(post.ess >= mix.plan.effective),
        "largest_weight_share": float(w[acc].max() / total) if total > 0 else None,
        "weight_share": share,
        "beyond": _beyond_cols({k: v[st >= 2] for k, v in pool.items()}, ev, mix.used),
        "envelope": None,
    }  # fmt: skip
    if mix.envelope is not None:
        from mwip.calibration.mixture import prior_density
        from mwip.hardware.prior import PRIOR

        e = mix.envelope
        rec["envelope"] = {
            "draws": int(len(mix.envelope_table)), "declared": mix.envelope_plan.draws,
            "max_draws": mix.envelope_plan.max_draws, "seed": mix.envelope_plan.seed,
            "ess_by_block": [float(v) for v in mix.envelope_ess],
            "low": e.lo[0].tolist(), "high": e.hi[0].tolist(),
            "fraction_of_prior": float(e.volumes[0] * prior_density(np.asarray(PRIOR.bounds))),
            "hit_rate": hits["envelope"] / max(int((st == 3).sum()), 1),
        }  # fmt: skip
    return rec


def _resampled(params: dict[str, np.ndarray], w: np.ndarray, accepted: np.ndarray,
               seed: int, n: int = MEMBERS) -> list[dict[str, float]]:  # fmt: skip
    """``n`` members by systematic resampling of the accepted draws under weights ``w``
    (one uniform offset from ``(seed, 1)``): each draw appears about ``n w / sum w`` times."""
    idx = np.nonzero(accepted)[0]
    if idx.size == 0:
        return []
    c = np.cumsum(w[idx])
    u0 = float(np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,))).random())
    pick = idx[np.minimum(np.searchsorted(c / c[-1], (u0 + np.arange(n)) / n), idx.size - 1)]
    return [{k: float(v[i]) for k, v in params.items()} for i in pick]


def analyse(table: Any, ev: Evidence, *, prior: Any = None, prior_draws: Any = None,
            chains: Any = None, mixture: Any = None) -> BookCalibration:  # fmt: skip
    """Condition the draws ``table`` (the prior draws of the calibration campaign, pooled
    with stage 2's box draws and their ``weight`` column, :mod:`mwip.calibration.proposal`)
    on the evidence ``ev`` and judge the held-out claims and numbers. ``prior_draws``: the
    plain prior draws (each run's standing rate in the prior; default ``table``).

    ``mixture``: stage 4's :class:`MixtureResult` (revision 3), whose draws ``table`` then
    also holds (:func:`mixture_pool`: balance-heuristic ``weight`` over stages 1, 2 and 4,
    stages 1-2's own in ``weight12``): the posterior of record is the weighted pool
    conditioned on ``mixture.used``, its most probable member the default twin; the chains
    (if given) are reported as stage 3's record only.

    ``chains`` without ``mixture``: stage 3's :class:`~mwip.calibration.chains.ChainResult`,
    which samples the posterior ``table`` conditioned (the same facts): the marginals, claims
    and numbers are then the chains' kept states, each interval at its effective size, and the
    default twin stays the pool's most probable member (every chain state meets the same
    facts, so its kernel ties with it or is smaller; the declared tie-break is the first in
    draw order)."""
    from mwip.calibration.claims import claim_rows, judge
    from mwip.calibration.posterior import condition, facts, weighted_quantile
    from mwip.calibration.runs import PUBLISHED, run_names
    from mwip.hardware.prior import PRIOR
    from mwip.hardware.twin import Twin

    pr = PRIOR if prior is None else prior
    pool = _cols(table)
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
        sampler = _mixture_record(mixture, post, table["sample"].to_numpy(), pool, ev)
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
    pcols = pool if prior_draws is None else _cols(prior_draws)
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
        doc["members"] = _resampled(params, post_w, accepted, mixture.plan.seed)
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
    ``posterior.json``, ``posterior.md``, ``twin.toml``, ``marginals.png`` (atomically).
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
    import pandas as pd

    from mwip.calibration.sample import calibration_campaign
    from mwip.campaign.execute import run_campaign
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
        from mwip.hardware.twin_config import twin_to_toml

        write_text_atomic(out / "twin.toml", provenance(res.doc) + twin_to_toml(
            res.twin, identified="most probable twin of the book calibration (above)"))
    names = res.doc["prior"]["names"]
    if mix is None and ch is not None and "sampler" in res.doc["posterior"]:
        post = {n: ch.x[:, :, j].reshape(-1) for j, n in enumerate(names)}
        wk = np.ones(ch.x.shape[0] * ch.x.shape[1])
    else:
        ok = res.accepted
        w = pop["weight"].to_numpy(dtype=float) if "weight" in pop else np.ones(len(ok))
        post = {n: pop[f"param.{n}"].to_numpy(dtype=float)[ok] for n in names}
        wk = w[ok]
    _figure(table, res.doc, post, wk, out / "marginals.png")
    return res


def box_sample(table: Any, ev: Evidence, box: Any, store: Path, *, jobs: int = 1,
               duration: float = 0.0, note: Callable[[str], None] | None = None) -> Any:
    """Stage 2 (:mod:`mwip.calibration.proposal`): the box draws, pooled with the prior draws
    ``table`` under the balance-heuristic weights (column ``weight``)."""
    import pandas as pd

    from mwip.calibration.proposal import inside, mis_weights, sample_box
    from mwip.calibration.sample import evaluate
    from mwip.hardware.prior import PRIOR

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
    from mwip.hardware.prior import PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    cols = _cols(pool)
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


def _evaluated(pool: Any, chains: Any) -> Any:
    """Every twin stages 1-3 evaluated, as one DataFrame (``param.<name>`` and the runs'
    columns): the pool and the chains' proposals inside the box."""
    import pandas as pd

    parts = [pool.drop(columns=[c for c in ("weight", "weight12") if c in pool.columns])]
    if chains is not None and chains.proposals is not None and len(chains.proposals):
        parts.append(chains.proposals.drop(columns=["chain", "generation", "inside", "moved"]))
    return pd.concat(parts, ignore_index=True)


def mixture_stage(pool: Any, chains: Any, ev: Evidence, plan: Any, store: Path, *,
                  duration: float = 0.0, envelope: Any = None, envelope_store: Path | None = None,
                  box: Any = None,
                  note: Callable[[str], None] | None = None) -> MixtureResult | None:  # fmt: skip
    """Stage 4 (:mod:`mwip.calibration.mixture`, revision 3): the facts to condition on (the
    largest consistent subset over every twin stages 1-3 evaluated), the seed set meeting
    them, the mixture fitted to it and its ``plan.draws`` draws, evaluated in blocks stored in
    ``store`` (``block-NNN.parquet``, replayed by a rerun; ``plan.json`` guards the folder
    against another plan or seed set). ``None`` when nothing was evaluated before.

    ``envelope`` (:class:`mwip.calibration.mixture.EnvelopePlan`, revision 4): then stage 5
    too, ``envelope.draws`` twins uniform on the bounding box of the seed set and stage 4's
    draws meeting the same facts, stored in ``envelope_store``; with ``envelope.max_draws``
    (revision 5) it goes on in blocks (``envelope_store/extension``) until the effective size
    of the pool (stages 1-2, whose box ``box`` is stage 2's, 4 and 5) reaches
    ``envelope.effective``."""
    from dataclasses import asdict

    from mwip.calibration.mixture import KernelMixture
    from mwip.calibration.posterior import consistent_subset, facts
    from mwip.calibration.proposal import sample_blocks
    from mwip.calibration.runs import run_names
    from mwip.calibration.sample import evaluate
    from mwip.calibration.stored import claim_folder
    from mwip.hardware.prior import PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    allt = _evaluated(pool, chains)
    if len(allt) == 0:
        return None
    f = facts(_cols(allt), run_names(), ev)
    mask, conflicts = consistent_subset(f)
    used = tuple(n for n, m in zip(f.names, mask, strict=True) if m)
    sel = np.all(f.S[:, mask], axis=1)
    seeds = allt[[f"param.{n}" for n in names]].to_numpy(dtype=float)[sel]
    q = KernelMixture.fit(seeds, bounds, plan.factors)
    claim_folder(store, {"plan": asdict(plan), "used": list(used), "names": names,
                         "seeds_sha256": hashlib.sha256(seeds.tobytes()).hexdigest()},
                 "draws of another mixture plan or seed set")  # fmt: skip

    def run(values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return evaluate(values, jobs=1, block=10**6, duration=duration)

    table = sample_blocks(lambda idx: q.draw(plan.seed, idx), plan.draws, names, run,
                          block=ev.block, store=store, note=note, offset=STAGE4_OFFSET,
                          label="mixture")  # fmt: skip
    res = MixtureResult(plan=plan, used=used, conflicts=tuple(tuple(c) for c in conflicts),
                        seeds=int(sel.sum()), evaluated=int(len(allt)), mixture=q,
                        table=table)  # fmt: skip
    if envelope is None or envelope_store is None:
        return res
    f4 = facts(_cols(table), run_names(), ev) if len(table) else None
    hits4 = (table[[f"param.{n}" for n in names]].to_numpy(dtype=float)[
        np.all(f4.S[:, mask], axis=1)] if f4 is not None else np.zeros((0, len(names))))
    env = KernelMixture.envelope(np.vstack([seeds, hits4]), bounds)
    # the identity of the sample, not of where it stops (revision 5 extends the same draws)
    ident = {"draws": envelope.draws, "seed": envelope.seed}
    claim_folder(envelope_store, {"plan": ident, "used": list(used), "names": names,
                                  "low": env.lo[0].tolist(), "high": env.hi[0].tolist()},
                 "draws of another envelope plan or envelope")  # fmt: skip
    etable = sample_blocks(lambda idx: env.draw(envelope.seed, idx), envelope.draws, names,
                           run, block=ev.block, store=envelope_store, note=note,
                           offset=STAGE5_OFFSET, label="envelope")  # fmt: skip
    res = replace(res, envelope_plan=envelope, envelope=env, envelope_table=etable)
    if envelope.max_draws is None or envelope.max_draws <= envelope.draws:
        return res
    # revision 5: block by block until the pooled effective size is the declared one
    import pandas as pd

    n0, parts, trail = envelope.draws, [etable], []
    ess = _pooled_ess(pool, box, res, mask, ev)
    if note is not None:
        note(f"envelope: {n0} draws, pooled effective size {ess:.1f}")
    k = 0
    while ess < float(envelope.effective) and n0 + k * ev.block < envelope.max_draws:
        size = min(ev.block, envelope.max_draws - n0 - k * ev.block)

        def draw(idx: Any) -> np.ndarray:  # extension draw i is stage 5's draw n0 + i
            return np.asarray(env.draw(envelope.seed, [n0 + i for i in idx]))

        new = sample_blocks(draw, k * ev.block + size, names, run, block=ev.block,
                            store=envelope_store / "extension", note=note,
                            offset=STAGE5_OFFSET + n0, label="envelope (extension)",
                            first=k)  # fmt: skip
        parts.append(new)
        res = replace(res, envelope_table=pd.concat(parts, ignore_index=True))
        ess = _pooled_ess(pool, box, res, mask, ev)
        trail.append(ess)
        k += 1
        if note is not None:
            note(f"envelope: {n0 + k * ev.block} draws, pooled effective size {ess:.1f} "
                 f"(stops at {float(envelope.effective):g})")
    return replace(res, envelope_ess=tuple(trail))


def _pooled_ess(pool: Any, box: Any, mix: MixtureResult, mask: np.ndarray,
                ev: Evidence) -> float:  # fmt: skip
    """Kish's effective size of the posterior that stages 1, 2, 4 and 5 pool (the facts
    ``mask``): the weights of its consistent twins only, as :func:`mixture_pool` gives them."""
    from mwip.calibration.mixture import balance_weights
    from mwip.calibration.posterior import facts
    from mwip.calibration.runs import run_names
    from mwip.hardware.prior import PRIOR

    names = [f"param.{n}" for n in PRIOR.names]
    tables = [pool.drop(columns=[c for c in ("weight", "weight12") if c in pool.columns])]
    tables += [t for _, _, t in mix.stages()]
    xs = []
    for t in tables:
        if len(t):
            ok = np.all(facts(_cols(t), run_names(), ev).S[:, mask], axis=1)
            xs.append(t[names].to_numpy(dtype=float)[ok])
    x = np.vstack(xs) if xs else np.zeros((0, len(names)))
    if x.shape[0] == 0:
        return 0.0
    n1 = int((pool["sample"].to_numpy() < 10**9).sum())
    p, counts, dens = _stage_densities(x, n1, len(pool) - n1, box, mix)
    w = balance_weights(p, counts, dens)
    return float(w.sum() ** 2 / np.sum(w * w))


def _stage_densities(x: np.ndarray, n1: int, n2: int, box: Any, mix: MixtureResult
                     ) -> tuple[np.ndarray, list[int], list[np.ndarray]]:  # fmt: skip
    """The prior density at ``x`` (N, D) and every pooled stage's draws and density there:
    the prior (``n1``), stage 2's box (``n2``, if any), stage 4's mixture, stage 5's
    envelope."""
    from mwip.calibration.mixture import prior_density
    from mwip.calibration.proposal import inside
    from mwip.hardware.prior import PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    p = np.full(x.shape[0], prior_density(bounds))
    dens, counts = [p], [n1]
    if box is not None and n2 > 0:
        dens.append(inside(x, box.ranges(names, bounds)) * p / box.fraction(names, bounds))
        counts.append(n2)
    for _, q, t in mix.stages():
        dens.append(q.density(x))
        counts.append(len(t))
    return p, counts, dens


def mixture_pool(prior_draws: Any, pool: Any, box: Any, mix: MixtureResult) -> Any:
    """Stages 1, 2, 4 and 5 pooled under the balance heuristic
    (:func:`mixture.balance_weights`: the prior, stage 2's box density, the mixture's and the
    envelope's, each with its number of draws):
    column ``weight``; stages 1-2's own weights stay in ``weight12`` (``nan`` for stage 4)."""
    import pandas as pd

    from mwip.calibration.mixture import balance_weights
    from mwip.hardware.prior import PRIOR

    names = list(PRIOR.names)
    old = pool["weight"] if "weight" in pool.columns else pd.Series(np.ones(len(pool)))
    base = pool.drop(columns=[c for c in ("weight",) if c in pool.columns]).assign(
        weight12=old.to_numpy(dtype=float))
    out = pd.concat([base] + [t.assign(weight12=np.nan) for _, _, t in mix.stages()],
                    ignore_index=True)  # fmt: skip
    x = out[[f"param.{n}" for n in names]].to_numpy(dtype=float)
    n1 = len(prior_draws)
    p, counts, dens = _stage_densities(x, n1, len(pool) - n1, box, mix)
    out["weight"] = balance_weights(p, counts, dens)
    return out


def provenance(doc: dict[str, Any]) -> str:
    """The comment block a calibrated twin file starts with."""
    p = doc["posterior"]
    lines = [
        "# The book's robot: the most probable twin of the posterior conditioned on the book's",
        "# evidence (`mwip twin fit --evidence book`; mwip/calibration/book-evidence.toml,",
        f"# sha256 {doc['evidence_sha256'][:16]}).",
        f"# Prior draws {doc.get('samples', p['n_prior'])} (seed {doc.get('seed')}), twins "
        + ("pooled (stages 1, 2, 4, 5)" if (p.get("sampler") or {}).get("kind") == "mixture"
           else "evaluated with stage 2")
        + f" {p['n_prior']}, consistent {p['size']} "
        f"(effective {p.get('effective_size', p['size']):.0f}); "
        f"conditioned on {len(p['used'])} facts"
        + (f", dropped {len(p['dropped'])}: {', '.join(p['dropped'])}" if p["dropped"] else "")
        + ".",
    ]
    smp = p.get("sampler") or {}
    if smp.get("kind") == "mixture":
        lines.append(f"# Stage 4 (revision 3): {smp['draws']} draws from a mixture of "
                     f"{smp['components']} box kernels on {smp['seeds']} seed twins, "
                     f"{smp['hits']['mixture']} consistent"
                     + (f"; stage 5 (revision 4): {smp['envelope']['draws']} draws uniform on "
                        f"the envelope, {smp['hits']['envelope']} consistent"
                        if smp.get("envelope") else "")
                     + f"; pooled with stages 1-2, effective size {p['effective_size']:.0f} ("
                     + ("precise" if smp["precise"] else "NOT precise") + f": declared "
                     f">= {smp['effective_needed']:g}).")  # fmt: skip
    s3 = p.get("stage3") or (smp if smp and smp.get("kind") != "mixture" else None)
    if s3:
        lines.append(f"# Stage 3: {s3['chains']} Metropolis chains x {s3['kept']} kept "
                     f"generations ({s3['evaluations']} twins evaluated), acceptance "
                     f"{s3['acceptance']:.2f}, smallest ESS {s3['ess_min']:.0f}, largest "
                     f"split R-hat {s3['rhat_max']:.3f} ("
                     + ("converged" if s3["converged"] else "NOT converged") + ").")  # fmt: skip
    return "\n".join(lines) + "\n"


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.0f} %"


def report_text(doc: dict[str, Any]) -> str:
    """``posterior.md``: the calibration in words."""
    p = doc["posterior"]
    out = [f"# {doc['title']}", "", f"Signals: {doc['signals']}.", "",
           f"Acceptance: {doc['acceptance']['rule']}.", "",
           f"Prior draws: {doc.get('samples', p['n_prior'])}; twins "
           + ("pooled (stages 1, 2, 4, 5; docs/twin_fit.md)"
              if (p.get("sampler") or {}).get("kind") == "mixture"
              else "evaluated with stage 2 (docs/twin_fit.md)")
           + f": {p['n_prior']}; consistent with the calibration evidence: "
           f"**{p['size']}** (effective size {p.get('effective_size', p['size']):.0f})."]
    # fmt: skip
    smp: dict[str, Any] = p.get("sampler") or {}
    s4: dict[str, Any] | None = smp if smp.get("kind") == "mixture" else None
    s3: dict[str, Any] | None = p.get("stage3") if s4 else (smp or None)
    if s4:
        s12 = p["stage12"]
        sh = s4["weight_share"]
        env = s4.get("envelope")
        out += ["", "## Stages 4-5: independent draws (revisions 3-5, the posterior of record)",
                "",
                f"Conditioned on the largest consistent subset over the "
                f"{s4['evaluated_before']} twins stages 1-3 evaluated ({len(p['used'])} "
                f"facts). {s4['seeds']} of them meet it (the seed set); stage 4 drew "
                f"{s4['draws']} twins from an equal-share mixture of {s4['components']} box "
                f"kernels on them (half-widths {', '.join(f'{x:g}' for x in s4['factors'])} "
                "x the seed set's standard deviation; mwip/calibration/mixture.py) and "
                "pooled them with stages 1-2 by the balance heuristic. "
                f"{s4['hits']['mixture']} of its draws meet the facts (hit rate "
                f"{s4['hit_rate']:.3f}); with stages 1-2 ({s4['hits']['prior']} prior, "
                f"{s4['hits']['box']} box draws) and stage 5 ({s4['hits']['envelope']} "
                f"envelope draws, below) the posterior has {p['size']} weighted "
                f"members, Kish effective size **{p['effective_size']:.0f}** ("
                + (f"precise: at least the declared {s4['effective_needed']:g})" if s4["precise"]
                   else f"**not precise**: under the declared {s4['effective_needed']:g}; the "
                   "intervals below are wide for it") + ". Share of the posterior weight: "
                f"prior draws {_pct(sh['prior'])}, box draws {_pct(sh['box'])}, mixture draws "
                f"{_pct(sh['mixture'])}, envelope draws {_pct(sh['envelope'])}; the largest single "
                f"weight carries "
                f"{_pct(s4['largest_weight_share'])}. Stages 1-2 alone met these facts with "
                f"{s4['hits']['prior'] + s4['hits']['box']} twin(s) (they conditioned on "
                f"{len(s12['used'])} facts). The weights are exact, so the estimate is "
                "unbiased; a region of the posterior the seed set missed is represented by "
                "the prior, box and envelope draws alone, which is what their weight share "
                "measures."]  # fmt: skip
        if env:
            ext = ("" if not env.get("max_draws") else
                   f" (revision 4 declared {env['declared']}; revision 5 went on in blocks until "
                   f"the pooled effective size reached the declared {s4['effective_needed']:g}"
                   f", at most {env['max_draws']})")  # fmt: skip
            out += ["", f"Stage 5: {env['draws']} twins{ext} uniform on the envelope, "
                    "the bounding box of every twin stages 1-4 found meeting the facts "
                    f"({env['fraction_of_prior']:.3g} of the prior's volume); "
                    f"{s4['hits']['envelope']} meet them (hit rate {env['hit_rate']:.4f}), "
                    f"carrying {_pct(sh['envelope'])} of the posterior weight. Pooled with "
                    "stages 1, 2 and 4 by the same balance heuristic: the effective size "
                    "above is of the whole pool."]  # fmt: skip
        b = s4["beyond"]
        out += ["", (f"A stage-4 or stage-5 twin met more facts than those conditioned on: "
                     f"{', '.join(b['extra'])} ({b['count']} draws). Not conditioned on "
                     "(revision 3 fixed the facts before its draws)." if b["extra"] else
                     "No stage-4 or stage-5 twin met a fact beyond those conditioned on.")]
        # fmt: skip
    if s3 and s4:
        out += ["", "## Stage 3: Markov chains (revision 2; their record)", "",
                f"{s3['chains']} random-walk Metropolis chains, {s3['burn']} generations of "
                f"burn-in and {s3['kept']} kept, {s3['evaluations']} twins evaluated; "
                f"acceptance {s3['acceptance']:.3f}; smallest ESS {s3['ess_min']:.0f}, "
                f"largest split R-hat {s3['rhat_max']:.3f}: "
                + ("converged." if s3["converged"] else "not converged.") + " Revision 3 "
                "uses their evaluated twins only to find stage 4's seed set; their states are "
                "not pooled (they are not independent draws from a known density)."]
    elif s3:
        s12 = p["stage12"]
        out += ["", "## Stage 3: Markov chains in the conditioned set", "",
                f"Stages 1-2 left {s12['size']} consistent twin(s) (effective size "
                f"{s12['effective_size']:.0f}). {s3['chains']} random-walk Metropolis chains "
                "started there and sampled the same posterior (the prior restricted to the "
                "twins meeting the conditioned facts; mwip/calibration/chains.py): "
                f"{s3['burn']} generations of adapting burn-in discarded, {s3['kept']} kept "
                f"per chain, {s3['evaluations']} twins evaluated; acceptance "
                f"{s3['acceptance']:.3f} (burn-in {s3['acceptance_burn_in']:.3f}). The "
                f"posterior's members are the {p['size']} kept states; every interval below "
                "is at its effective sample size (ESS), not at the count. Smallest ESS over "
                f"the unknowns {s3['ess_min']:.0f}, largest split R-hat "
                f"{s3['rhat_max']:.3f} (near 1 when the chains agree): "
                + (f"**converged** (below {s3['converged_below']:g})." if s3["converged"] else
                   f"**not converged** (the declared threshold is {s3['converged_below']:g}): "
                   "the chains still remember where they started, the intervals below "
                   "understate the uncertainty and the verdicts are provisional."),
                "",
                "| unknown | ESS | split R-hat |", "|---|---|---|"]
        out += [f"| {n} | {e:.0f} | {s3['rhat'][n]:.3f} |" for n, e in s3["ess"].items()]
        b = s3["beyond"]
        out += ["", (f"A twin the chains evaluated met more facts than those conditioned on: "
                     f"{', '.join(b['extra'])} ({b['count']} proposals). The conditioning "
                     "stays that of stages 1-2 (declared before the chains ran)."
                     if b["extra"] else "No twin the chains evaluated met a fact beyond those "
                     "conditioned on.")]  # fmt: skip
        wd = s3.get("wider")
        if wd:
            out += ["", "### The original rule over every twin evaluated (secondary)", "",
                    f"Over all {wd['twins_evaluated']} twins evaluated (stages 1-3), the "
                    f"largest consistent subset has {len(wd['used'])} facts (also "
                    f"{', '.join(wd['extra'])}), met by {wd['twins_meeting']} of them. "
                    f"{wd['kept_states']} of the {wd['of_kept']} kept chain states (from "
                    f"{wd['chains']} chains) meet it: restricted to them, the chain sample is "
                    "a sample of the posterior on that larger set, as (un)converged as the "
                    "chains. Not the declared conditioning (revision 2 fixed stages 1-2's "
                    "subset before the chains ran); shown because the rule of the first "
                    "declaration, applied to every twin evaluated, gives it.", "",
                    "| claim | holds in (kept states on the larger set) | verdict |",
                    "|---|---|---|"]  # fmt: skip
            out += [f"| {c['claim']} | {_pct(c['fraction'])} | {c['verdict']} |"
                    for c in wd["claims"]]
    if p["conflicts"]:
        over = ("the twins stages 1-3 evaluated" if s4 else "stages 1-2")
        out += ["", f"The calibration facts conflict: no twin of {over} satisfies them all. "
                f"Smallest conflicting sets (over {over}"
                + ("" if s4 else "; stage 3 above may have met some") + "):"]
        out += [f"- {{{', '.join(c)}}}" for c in p["conflicts"]]
        out += ["", f"Conditioned on the largest consistent subset ({len(p['used'])} facts); "
                f"not used: {', '.join(p['dropped'])}."]
    out += ["", "## Each run standing in the prior (the 2,000 prior draws)", "",
            "| run | stands in |", "|---|---|"]
    out += [f"| {r} | {_pct(v)} |" for r, v in doc["standing_in_prior"].items()]
    out += ["", "## Marginals", "",
            "| unknown | prior | posterior 5-50-95 % | identified |", "|---|---|---|---|"]
    unsure = (not s4["precise"]) if s4 else bool(s3 and not s3["converged"])
    for name, m in p["marginals"].items():
        post = (f"{m['q05']:.4g} - {m['median']:.4g} - {m['q95']:.4g}" if "median" in m
                else "n/a")  # fmt: skip
        ident = "yes" if m["identified"] else "no"
        if unsure and m["identified"]:
            ident = ("yes, provisional (effective size under the declared)" if s4 else
                     "yes, provisional (chains not converged)")
        out.append(f"| {name} | {m['prior'][0]:g} .. {m['prior'][1]:g} | {post} | {ident} |")
    c = doc["claim_counts"]
    out += ["", "## Held-out claims", "",
            f"{c['holds']} hold, {c['fails']} fail, {c['undecided']} undecided "
            f"(of {len(doc['claims'])}).", "",
            "| claim | holds in (95 % CI) | verdict | most probable twin | decided by |",
            "|---|---|---|---|---|"]  # fmt: skip
    for cl in doc["claims"]:
        ci = ("n/a" if cl["fraction"] is None else
              f"{_pct(cl['fraction'])} ({_pct(cl['interval'][0])}-{_pct(cl['interval'][1])}, "
              f"n = {cl['n']})")  # fmt: skip
        by = cl.get("decided_by")
        bytext = (f"{by['parameter']} (holds when {by['holds_when']}; AUC {by['auc']:.2f})"
                  if by else "")  # fmt: skip
        dflt = {True: "holds", False: "fails", None: "n/a"}[cl["default_twin"]]  # MAP member
        out.append(f"| {cl['study']}/{cl['id']}: {cl['text']} | {ci} | {cl['verdict']} | "
                   f"{dflt} | {bytext} |")  # fmt: skip
    out += ["", "## Numbers of Tables 6.4-6.8 (measured signals)", "",
            "| number | role | book | posterior 2.5-50-97.5 % | inside | most probable twin |",
            "|---|---|---|---|---|---|"]  # fmt: skip
    for nm in doc["numbers"]:
        rng = (f"{nm['low']:.4g} - {nm['median']:.4g} - {nm['high']:.4g}" if "median" in nm
               else "n/a")  # fmt: skip
        ins = {True: "yes", False: "no"}.get(nm.get("inside"), "n/a")
        d = nm.get("default_twin")
        out.append(f"| {nm['key']} | {nm['role']} | {nm['book']:g} | {rng} | {ins} | "
                   f"{'n/a' if d is None or not np.isfinite(d) else format(d, '.4g')} |")
    return "\n".join(out) + "\n"


def _figure(table: Any, doc: dict[str, Any], post: dict[str, np.ndarray], weights: np.ndarray,
            path: Path) -> None:  # fmt: skip
    """Prior draws against the posterior (its members ``post``, importance ``weights``), a
    density histogram per unknown (``marginals.png``)."""
    from matplotlib.figure import Figure

    from mwip.io import write_atomic

    names = doc["prior"]["names"]
    pd_ = doc["posterior"]
    cols = 4
    rows = (len(names) + cols - 1) // cols
    fig = Figure(figsize=(3.2 * cols, 2.4 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, name, (lo, hi) in zip(axes, names, doc["prior"]["bounds"], strict=False):
        x = table[f"param.{name}"].to_numpy(dtype=float)
        bins = np.linspace(lo, hi, 21) if hi > lo else 5
        ax.hist(x, bins=bins, density=True, color="0.8", label="prior draws")
        if weights.size:
            ax.hist(post[name], bins=bins, weights=weights, density=True, color="tab:blue",
                    alpha=0.7, label="posterior (weighted)")  # fmt: skip
        if pd_["map_index"] >= 0:
            ax.axvline(doc["map_values"][name], color="tab:red", lw=1.2, label="most probable")
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=7)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    axes[0].legend(fontsize=7)
    what = "the book's calibration evidence" if not pd_["dropped"] else (
        f"the largest consistent subset of it ({len(pd_['used'])} facts)")
    fig.suptitle(f"Twin unknowns: prior ({len(table)} draws) and the "
                 f"{pd_['size']} twins consistent with {what}",
                 fontsize=10)  # fmt: skip
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=90))
