"""The book calibration in words and a figure: ``posterior.md``, the twin file's provenance
comment, ``marginals.png`` (from the document :func:`mwip.calibration.book.analyse` writes to
``posterior.json``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["figure", "provenance", "report_text"]


def provenance(doc: dict[str, Any]) -> str:
    """The comment block a calibrated twin file starts with."""
    p = doc["posterior"]
    lines = [
        "# The book's robot: the most probable twin of the posterior conditioned on the book's",
        "# evidence (`mwip twin calibrate book --record`; mwip/calibration/book-evidence.toml,",
        f"# sha256 {doc['evidence_sha256'][:16]}).",
        f"# {p['n_prior']:,} twins drawn ({doc.get('samples', p['n_prior'])} from the prior, "
        f"seed {doc.get('seed')}"
        + (", then the later searches" if p["n_prior"] != doc.get("samples", p["n_prior"])
           else "")
        + f"), {p['size']:,} consistent with the calibration facts, whose weights count as "
        f"about {p.get('effective_size', p['size']):.0f} equally weighted twins; "
        f"conditioned on {len(p['used'])} facts"
        + (f"; {len(p['dropped'])} that no twin met together with them were dropped: "
           f"{', '.join(p['dropped'])}" if p["dropped"] else "")
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


def figure(table: Any, doc: dict[str, Any], post: dict[str, np.ndarray], weights: np.ndarray,
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
