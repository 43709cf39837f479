"""``mwip twin fit --evidence book``: the book's robot conditioned on the book's evidence.

1. Draw the twin's prior (:mod:`mwip.hardware.prior`; ``samples`` draws, ``seed``) and run
   every Chapter 6 run on every draw: a campaign of ``kind = "calibration"`` (Dask, chunked,
   resumable, deterministic: :mod:`mwip.calibration.sample`) in ``OUT/prior-draws``.
2. Condition on the calibration evidence declared in ``book-evidence.toml`` before any fit
   (:mod:`mwip.calibration.posterior`): facts, acceptance, the smallest conflicting sets and
   the largest consistent subset if the facts conflict, marginals, the most probable member.
3. Judge the held-out evidence on every consistent twin (:mod:`mwip.calibration.claims`) and
   the held-out numbers of Tables 6.4-6.8 against the posterior's predictive range.

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


@dataclass(frozen=True)
class BookCalibration:
    """The result: the document written to ``posterior.json`` and the most probable twin."""

    doc: dict[str, Any]
    twin: Any
    accepted: np.ndarray  # (N,) the draws consistent with the facts conditioned on


def _evidence_hash() -> str:
    return hashlib.sha256(EVIDENCE_FILE.read_bytes()).hexdigest()


def _cols(table: Any) -> dict[str, np.ndarray]:
    return {c: table[c].to_numpy(dtype=float) for c in table.columns
            if c not in ("evidence", "sample")}  # fmt: skip


def analyse(table: Any, ev: Evidence, *, prior: Any = None,
            prior_draws: Any = None) -> BookCalibration:  # fmt: skip
    """Condition the draws ``table`` (the prior draws of the calibration campaign, pooled
    with stage 2's box draws and their ``weight`` column, :mod:`mwip.calibration.proposal`)
    on the evidence ``ev`` and judge the held-out claims and numbers. ``prior_draws``: the
    plain prior draws (each run's standing rate in the prior; default ``table``)."""
    from mwip.calibration.claims import claim_rows, judge
    from mwip.calibration.posterior import condition, facts, weighted_quantile
    from mwip.calibration.runs import PUBLISHED, run_names
    from mwip.hardware.prior import PRIOR
    from mwip.hardware.twin import Twin

    pr = PRIOR if prior is None else prior
    cols = _cols(table)
    params = {n: cols[f"param.{n}"] for n in pr.names}
    bounds = {n: (float(lo), float(hi)) for n, (lo, hi) in zip(pr.names, pr.bounds, strict=True)}
    names = run_names()
    f = facts(cols, names, ev)
    weights = cols.get("weight")
    post = condition(f, params, bounds, ev, weights=weights)
    verdicts = claim_rows(cols)
    claims = judge(verdicts, post.accepted, params, post.map_index, ev.decided,
                   weights=post.weights)  # fmt: skip
    calib = {n.key for n in ev.numbers}
    numbers = []
    lo_q, hi_q = (1 - ev.interval) / 2, 1 - (1 - ev.interval) / 2
    for key, book in PUBLISHED.items():
        x = cols[key][post.accepted] if key in cols else np.zeros(0)
        wx = post.weights[post.accepted][np.isfinite(x)] if key in cols else np.zeros(0)
        x = x[np.isfinite(x)]
        entry: dict[str, Any] = {"key": key, "book": book, "role": "calibration" if key in calib
                                 else "held-out", "n": int(x.size)}  # fmt: skip
        if x.size:
            lo, med, hi = (float(v) for v in weighted_quantile(x, wx, [lo_q, 0.5, hi_q]))
            entry.update(low=lo, median=med, high=hi, inside=bool(lo <= book <= hi))
        if post.map_index >= 0 and key in cols:
            entry["default_twin"] = float(cols[key][post.map_index])
        numbers.append(entry)
    map_standing = ({r: bool(cols[f"{r}.stands"][post.map_index] == 1.0) for r in names}
                    if post.map_index >= 0 else {})  # fmt: skip
    pcols = cols if prior_draws is None else _cols(prior_draws)
    standing = {r: float(np.mean(pcols[f"{r}.stands"])) for r in names}
    map_values: dict[str, float] = {}
    twin = None
    if post.map_index >= 0:
        map_values = {n: float(params[n][post.map_index]) for n in pr.names}
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
                                 "map": (float(cols[n.key][post.map_index])
                                         if post.map_index >= 0 else None)}
                                for n in ev.numbers],  # fmt: skip
        "posterior": post.summary(),
        "map_values": map_values,
        "map_standing": map_standing,
        "claims": claims,
        "claim_counts": counts,
        "numbers": numbers,
        "evaluated": int(len(table)),
    }
    return BookCalibration(doc, twin, post.accepted)


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
    note: Callable[[str], None] | None = None,
) -> BookCalibration:
    """Run (or resume) the book calibration into ``out``; returns the result and writes
    ``posterior.json``, ``posterior.md``, ``twin.toml``, ``marginals.png`` (atomically).
    ``samples``, ``seed``, ``block`` default to the declaration's; ``duration`` > 0 caps every
    run (a smoke test: its verdicts are not the book's experiments). ``proposal``: stage 2's
    box sample (:class:`mwip.calibration.proposal.BoxProposal`; ``True``: the declaration's,
    ``None``: none), ``proposal_draws`` its size (a smoke test); ``note`` receives one line per
    stage-2 block."""
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
    res = analyse(pop, ev, prior_draws=table)
    res.doc["samples"] = camp.samples
    res.doc["seed"] = camp.seed
    res.doc["duration_cap"] = duration or None
    write_json_atomic(out / POSTERIOR_FILE, res.doc)
    write_text_atomic(out / "posterior.md", report_text(res.doc))
    if res.twin is not None:
        from mwip.hardware.twin_config import twin_to_toml

        write_text_atomic(out / "twin.toml", provenance(res.doc) + twin_to_toml(
            res.twin, identified="most probable twin of the book calibration (above)"))
    ok = res.accepted
    w = pop["weight"].to_numpy(dtype=float) if "weight" in pop else np.ones(len(ok))
    post = {n: pop[f"param.{n}"].to_numpy(dtype=float)[ok] for n in res.doc["prior"]["names"]}
    _figure(table, res.doc, post, w[ok], out / "marginals.png")
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


def provenance(doc: dict[str, Any]) -> str:
    """The comment block a calibrated twin file starts with."""
    p = doc["posterior"]
    lines = [
        "# The book's robot: the most probable twin of the posterior conditioned on the book's",
        "# evidence (`mwip twin fit --evidence book`; mwip/calibration/book-evidence.toml,",
        f"# sha256 {doc['evidence_sha256'][:16]}).",
        f"# Prior draws {doc.get('samples', p['n_prior'])} (seed {doc.get('seed')}), twins "
        f"evaluated with stage 2 {p['n_prior']}, consistent {p['size']} "
        f"(effective {p.get('effective_size', p['size']):.0f}); "
        f"conditioned on {len(p['used'])} facts"
        + (f", dropped {len(p['dropped'])}: {', '.join(p['dropped'])}" if p["dropped"] else "")
        + ".",
    ]
    return "\n".join(lines) + "\n"


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.0f} %"


def report_text(doc: dict[str, Any]) -> str:
    """``posterior.md``: the calibration in words."""
    p = doc["posterior"]
    out = [f"# {doc['title']}", "", f"Signals: {doc['signals']}.", "",
           f"Acceptance: {doc['acceptance']['rule']}.", "",
           f"Prior draws: {doc.get('samples', p['n_prior'])}; twins evaluated with stage 2 "
           f"(docs/twin_fit.md): {p['n_prior']}; consistent with the calibration evidence: "
           f"**{p['size']}** (effective size {p.get('effective_size', p['size']):.0f})."]
    # fmt: skip
    if p["conflicts"]:
        out += ["", "The calibration facts conflict: no draw satisfies them all. Smallest "
                "conflicting sets:"]
        out += [f"- {{{', '.join(c)}}}" for c in p["conflicts"]]
        out += ["", f"Conditioned on the largest consistent subset ({len(p['used'])} facts); "
                f"not used: {', '.join(p['dropped'])}."]
    out += ["", "## Each run standing in the prior (the 2,000 prior draws)", "",
            "| run | stands in |", "|---|---|"]
    out += [f"| {r} | {_pct(v)} |" for r, v in doc["standing_in_prior"].items()]
    out += ["", "## Marginals", "",
            "| unknown | prior | posterior 5-50-95 % | identified |", "|---|---|---|---|"]
    for name, m in p["marginals"].items():
        post = (f"{m['q05']:.4g} - {m['median']:.4g} - {m['q95']:.4g}" if "median" in m
                else "n/a")  # fmt: skip
        out.append(f"| {name} | {m['prior'][0]:g} .. {m['prior'][1]:g} | {post} | "
                   f"{'yes' if m['identified'] else 'no'} |")  # fmt: skip
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
    fig.suptitle(f"Twin unknowns: prior ({pd_['n_prior']} draws) and the "
                 f"{pd_['size']} twins consistent with {what}",
                 fontsize=10)  # fmt: skip
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=90))
