"""Stages 4-5 of the book calibration: the pooled importance sample of record (revisions 3-5
of ``book-evidence.toml``).

Stage 4 draws from a box-kernel mixture fitted to the twins stages 1-3 found meeting the facts
(:class:`mwip.calibration.mixture.KernelMixture`), stage 5 uniformly on their envelope (and,
by revision 5, on until the pooled effective size is the declared one); both are pooled with
stages 1-2 under the balance heuristic (:func:`mwip.calibration.mixture.balance_weights`),
whose exact weights make the pool an unbiased estimate of the posterior: the prior restricted
to the twins meeting the facts conditioned on. :func:`mwip.calibration.book.analyse` judges
the held-out evidence on it.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mwip.calibration.evidence import Evidence

__all__ = ["MixtureResult", "STAGE4_OFFSET", "STAGE5_OFFSET", "MEMBERS", "beyond_cols",
           "mixture_pool", "mixture_stage", "pooled_record", "resampled", "table_cols"]

#: ``sample`` of stage 4's draw ``s`` is ``STAGE4_OFFSET + s`` (stage 2's: 10^9 + s; stage 1's: s).
STAGE4_OFFSET = 2 * 10**9
#: ... and of stage 5's, ``STAGE5_OFFSET + s``.
STAGE5_OFFSET = 3 * 10**9

#: Posterior members written to ``posterior.json`` by stage 4 (systematic resampling).
MEMBERS = 256


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

    def stages(self) -> list[tuple[Any, Any]]:
        """``(density, draws)`` of stage 4 and (if run) stage 5."""
        out = [(self.mixture, self.table)]
        if self.envelope is not None:
            out.append((self.envelope, self.envelope_table))
        return out


def table_cols(table: Any) -> dict[str, np.ndarray]:
    return {c: table[c].to_numpy(dtype=float) for c in table.columns
            if c not in ("evidence", "sample")}  # fmt: skip


def beyond_cols(cols: dict[str, np.ndarray], ev: Evidence,
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


def pooled_record(mix: MixtureResult, post: Any, sample: np.ndarray,
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
        "beyond": beyond_cols({k: v[st >= 2] for k, v in pool.items()}, ev, mix.used),
        "envelope": None,
    }  # fmt: skip
    if mix.envelope is not None:
        from mwip.calibration.mixture import prior_density
        from mwip.calibration.structure import BOOK_PRIOR as PRIOR

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


def resampled(params: dict[str, np.ndarray], w: np.ndarray, accepted: np.ndarray,
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
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    allt = _evaluated(pool, chains)
    if len(allt) == 0:
        return None
    f = facts(table_cols(allt), run_names(), ev)
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
    f4 = facts(table_cols(table), run_names(), ev) if len(table) else None
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

    from mwip.calibration.mixture import balance_weights

    n0, parts, trail = envelope.draws, [etable], []
    n1 = int((pool["sample"].to_numpy() < 10**9).sum())
    base = pool.drop(columns=[c for c in ("weight", "weight12") if c in pool.columns])
    # the consistent twins so far, each table's found once
    found = [_consistent_x(t, mask, ev) for t in (base, table, etable)]

    def pooled_ess(n_env: int) -> float:
        x = np.vstack(found)
        if x.shape[0] == 0:
            return 0.0
        p, counts, dens = _stage_densities(x, n1, len(pool) - n1, box,
                                           [(q, len(table)), (env, n_env)])  # fmt: skip
        w = balance_weights(p, counts, dens)
        return float(w.sum() ** 2 / np.sum(w * w))

    ess = pooled_ess(n0)
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
        found.append(_consistent_x(new, mask, ev))
        k += 1
        ess = pooled_ess(n0 + sum(len(t) for t in parts[1:]))
        trail.append(ess)
        if note is not None:
            note(f"envelope: {n0 + k * ev.block} draws, pooled effective size {ess:.1f} "
                 f"(stops at {float(envelope.effective):g})")
    return replace(res, envelope_table=pd.concat(parts, ignore_index=True),
                   envelope_ess=tuple(trail))  # fmt: skip


def _consistent_x(t: Any, mask: np.ndarray, ev: Evidence) -> np.ndarray:
    """The unknowns (n, D) of the twins of table ``t`` that meet the facts ``mask``."""
    from mwip.calibration.posterior import facts
    from mwip.calibration.runs import run_names
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = [f"param.{n}" for n in PRIOR.names]
    if len(t) == 0:
        return np.zeros((0, len(names)))
    ok = np.all(facts(table_cols(t), run_names(), ev).S[:, mask], axis=1)
    return np.asarray(t[names].to_numpy(dtype=float)[ok])


def _stage_densities(x: np.ndarray, n1: int, n2: int, box: Any,
                     stages: list[tuple[Any, int]]
                     ) -> tuple[np.ndarray, list[int], list[np.ndarray]]:  # fmt: skip
    """The prior density at ``x`` (N, D) and every pooled stage's draws and density there:
    the prior (``n1``), stage 2's box (``n2``, if any), then ``stages``' ``(density, draws)``
    (stage 4's mixture, stage 5's envelope)."""
    from mwip.calibration.mixture import prior_density
    from mwip.calibration.proposal import inside
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = list(PRIOR.names)
    bounds = np.asarray(PRIOR.bounds, dtype=float)
    p = np.full(x.shape[0], prior_density(bounds))
    dens, counts = [p], [n1]
    if box is not None and n2 > 0:
        dens.append(inside(x, box.ranges(names, bounds)) * p / box.fraction(names, bounds))
        counts.append(n2)
    for q, n in stages:
        dens.append(q.density(x))
        counts.append(n)
    return p, counts, dens


def mixture_pool(prior_draws: Any, pool: Any, box: Any, mix: MixtureResult) -> Any:
    """Stages 1, 2, 4 and 5 pooled under the balance heuristic
    (:func:`mixture.balance_weights`: the prior, stage 2's box density, the mixture's and the
    envelope's, each with its number of draws):
    column ``weight``; stages 1-2's own weights stay in ``weight12`` (``nan`` for stage 4)."""
    import pandas as pd

    from mwip.calibration.mixture import balance_weights
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    names = list(PRIOR.names)
    old = pool["weight"] if "weight" in pool.columns else pd.Series(np.ones(len(pool)))
    base = pool.drop(columns=[c for c in ("weight",) if c in pool.columns]).assign(
        weight12=old.to_numpy(dtype=float))
    out = pd.concat([base] + [t.assign(weight12=np.nan) for _, t in mix.stages()],
                    ignore_index=True)  # fmt: skip
    x = out[[f"param.{n}" for n in names]].to_numpy(dtype=float)
    n1 = len(prior_draws)
    p, counts, dens = _stage_densities(x, n1, len(pool) - n1, box,
                                       [(q, len(t)) for q, t in mix.stages()])  # fmt: skip
    out["weight"] = balance_weights(p, counts, dens)
    return out
