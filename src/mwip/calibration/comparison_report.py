"""Revisions 6-9's comparison in words (``structures.md``, from the document of
:func:`mwip.calibration.comparison.analyse_table`)."""

from __future__ import annotations

from typing import Any

__all__ = ["report_md", "headline"]


def _g(x: Any, fmt: str = ".3g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float) and x != x:
        return "-"
    if x == float("inf"):
        return "inf"
    return format(x, fmt)


def headline(doc: dict[str, Any]) -> str:
    """One paragraph a reader takes without the docs."""
    st = doc["structures"]
    post = doc["posterior_probability"]
    parts = []
    for n, s in st.items():
        if s["rejected"]:
            parts.append(f"{n} met every calibration fact with none of its {s['searched']:,} "
                         f"twins (the most facts one twin met together: "
                         f"{s['most_facts_together']} of {len(s['facts_met_share'])})")
        elif post[n] > 0:
            parts.append(f"{n} met them with {s['found']:,} of its {s['searched']:,} twins "
                         f"(probability {post[n]:.3g} given the facts, from Z = "
                         f"{s['evidence']:.3g} by importance sampling; its posterior's "
                         f"effective size {s['conditioned_effective']:.1f})")  # fmt: skip
        else:
            parts.append(f"{n} met them with {s['found']:,} of its {s['searched']:,} twins, "
                         f"found by search (none of its {s['draws']:,} prior draws: Z below "
                         f"{s['evidence_95'][1]:.2g}, so no probability given the facts)")
    c = doc["claim_counts"]
    m = doc.get("member")
    robot = (f" The default robot is {m['structure']}'s most probable member (its "
             f"calibration numbers nearest the book's)." if m else "")
    if not any(v > 0 for v in post.values()):
        why = ("no structure met every calibration fact with any of its prior draws, so none "
               "has a probability given the facts; each structure's own verdicts, on its twins "
               "meeting its largest consistent subset, are in the claims table")  # fmt: skip
    else:
        why = "a claim not judgeable compares a run that no twin of a likely structure kept up"
    return ("; ".join(parts) + f". Held-out claims over the structures: {c['holds']} hold, "
            f"{c['fails']} fail, {c['undecided']} undecided, {c['not judgeable']} not "
            f"judgeable ({why}).{robot}")


def report_md(doc: dict[str, Any]) -> str:
    """The whole comparison as Markdown."""
    st = doc["structures"]
    out = ["# The book's robot: twin structures compared by their evidence (revisions 6-9)",
           "", "Declared in `src/mwip/calibration/book-structures.toml` before any draw "
           f"(sha256 {doc.get('declaration_sha256', '?')[:12]}); the split, the tolerance and "
           "the verdict rule are `book-evidence.toml`'s. Rebuilt from the per-twin file by "
           "`mwip twin calibrate book --replay FILE --out DIR`.", "", headline(doc), "",
           "## Evidence", "",
           "| structure | twins (A + B + C + D) | found meeting every fact (C, D) | Z = P(prior "
           "meets every fact) [95 %], from | p(S given the facts) | most facts together | "
           "rejected by |",
           "|---|---|---|---|---|---|---|"]  # fmt: skip
    post = doc["posterior_probability"]
    for n, s in st.items():
        lo, hi = s["evidence_95"]
        rej = ", ".join(f"`{f}`" for f in s["rejected_by"]) or "-"
        c = s["stages"].get("C", 0)
        d = s["stages"].get("D", 0)
        hit = s["hits_by_stage"]
        out.append(f"| {n}: {s['title']} | {s['stages']['A']:,} + {s['stages']['B']:,} + "
                   f"{c:,} + {d:,} | {s['found']:,} ({hit.get('C', 0):,}, {hit.get('D', 0):,}) "
                   f"| {_g(s['evidence'])} [{_g(lo)}, {_g(hi)}], stage {'D' if d else 'A'} | "
                   f"{_g(post[n])} | {s['most_facts_together']} of "
                   f"{len(s['facts_met_share'])} | {rej} |")  # fmt: skip
    out += ["", "A structure none of whose twins meets every calibration fact is rejected by "
            "the facts outside its largest consistent subset: \"structure rejected by this "
            "fact\", not a held-out failure. Z's upper bound then says how rare such twins "
            "could still be under its prior. Stage C (revision 8) is a directed search run only "
            "where stages A and B found no twin meeting every fact: it finds, it does not weigh. "
            "Stage D (revision 9) runs where a twin meets every fact: importance sampling from "
            "a proposal around those twins, fixed before its draws (a tenth of it the prior "
            "itself), so its weights are exact and Z is its estimate; a small effective size "
            "says a few heavy draws carry it.", "", "## Bayes factors", "",
            "| B = Z_a / Z_b | B | 95 % |", "|---|---|---|"]  # fmt: skip
    for k, b in doc["bayes_factors"].items():
        out.append(f"| {k} | {_g(b['B'])} | [{_g(b['lo'])}, {_g(b['hi'])}] |")
    for n, s in st.items():
        if s.get("posterior"):
            out += ["", f"## {n}: its posterior (stage D's twins meeting every fact, weighted)",
                    "", f"{s['conditioned_draws']:,} twins of stage D weighted by their "
                    f"importance weights (Kish effective size "
                    f"{s['conditioned_effective']:.1f}): the prior conditioned on the 27 facts "
                    "(revision 9).", ""]  # fmt: skip
        else:
            out += ["", f"## {n}: the twins found meeting its largest consistent subset", "",
                    f"{s['conditioned_draws']:,} twins of stages A, B and C, unweighted: a "
                    "description of the twins found, not a posterior (revisions 7-8).",
                    ""]  # fmt: skip
        if s.get("offset"):
            o = s["offset"]
            out += [f"Pitch-estimate offset {o['what']}: median {_g(o['q50'])} rad "
                    f"(90 %: {_g(o['q05'])}-{_g(o['q95'])}).", ""]  # fmt: skip
        out += ["| unknown | 5 % | median | 95 % | range | at a wall |",
                "|---|---|---|---|---|---|"]  # fmt: skip
        for u, m in s["marginals"].items():
            wall = f"**{m['wall']}**" if m["wall"] else "-"
            out.append(f"| {u} | {_g(m['q05'])} | {_g(m['q50'])} | {_g(m['q95'])} | "
                       f"{_g(m['prior'][0])}-{_g(m['prior'][1])} | {wall} |")  # fmt: skip
        walls = [u for u, m in s["marginals"].items() if m["wall"]]
        if walls:
            out += ["", "Warning: more than half of these twins have " + ", ".join(walls)
                    + " at a wall of the prior (the outer 5 % of its range): a missing "
                    "element or too narrow a prior may hold them there."]  # fmt: skip
        miss = {f: v for f, v in s["facts_met_share"].items() if v is not None and v < 1}
        if miss:
            out += ["", "The share of these twins meeting each fact outside the subset: "
                    + ", ".join(
                        f"`{f}` {v:.2f}" for f, v in miss.items())]  # fmt: skip
    m = doc.get("member")
    if m:
        out += ["", "## The default robot", "",
                f"The most probable member of the most probable structure, {m['structure']}: "
                f"stage {m['stage']} draw {m['sample']}, the largest ABC kernel of the "
                "calibration numbers among its posterior's twins (ln kernel "
                f"{m['log_kernel']:.3g}); `robot.toml` beside this page, shipped as "
                "`src/mwip/robot/book.toml`.", "",
                "| number | book | this twin |", "|---|---|---|"]  # fmt: skip
        out += [f"| {k} | {_g(m['book'][k], '.4g')} | {_g(v, '.4g')} |"
                for k, v in m["numbers"].items()]
        out += ["", "| unknown | value |", "|---|---|"]
        out += [f"| {k} | {_g(v, '.4g')} |" for k, v in m["values"].items()]
    names = list(st)
    out += ["", "## Held-out claims", "",
            "| claim | " + " | ".join(f"{n} ({st[n]['conditioned_draws']:,} twins)"
                                     for n in names)
            + " | over structures | revisions 1-5 (S0) |",
            "|---|" + "---|" * len(names) + "---|---|"]  # fmt: skip
    for c in doc["claims"]:
        cells = []
        for n in names:
            p = c["per_structure"][n]
            cells.append(p["verdict"] + (f" ({p['share']:.2f})" if p["share"] is not None
                                         else ""))  # fmt: skip
        over = c["verdict"] + (f" ({c['p_holds']:.2f})" if c["p_holds"] is not None else "")
        out.append(f"| {c['claim']}: {c['text']} | " + " | ".join(cells)
                   + f" | {over} | {c['revisions_1_5'] or '-'} |")  # fmt: skip
    out += ["", "A claim is \"not judgeable on S\" when it compares a run that a fact "
            "rejecting S says must stand; the verdict over structures averages the others by "
            "their probability given the facts (holds at >= 0.95, fails at <= 0.05)."]
    return "\n".join(out) + "\n"
