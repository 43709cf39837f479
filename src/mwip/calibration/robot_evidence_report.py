"""A robot's calibration on its facts in words (``calibration.md``, from the document of
:func:`mwip.calibration.robot_evidence.analyse`)."""

from __future__ import annotations

from typing import Any

__all__ = ["report_md", "headline"]


def _g(x: Any) -> str:
    return "-" if x is None else format(float(x), ".4g")


def headline(doc: dict[str, Any]) -> str:
    """One paragraph a reader takes without the docs."""
    s = doc["structure"]
    n = len(doc["facts"])
    lo, hi = s["evidence_95"]
    if s["rejected"]:
        return (f"No twin of the robot's prior met all {n} facts ({s['searched']:,} twins "
                f"searched; the most one twin met together: {s['most_facts_together']}): the "
                f"robot's structure is rejected by {', '.join(s['rejected_by'])}. No robot "
                "file is written: the robot file's structure or prior cannot make what it did "
                "(a missing or wrong element, or a range too narrow), which no choice of its "
                "unknowns mends.")  # fmt: skip
    ident = [k for k, m in doc["marginals"].items() if m["identified"]]
    walls = [k for k, m in doc["marginals"].items() if m["wall"]]
    return (f"{doc['consistent']:,} of {s['searched']:,} twins met all {n} facts; the prior "
            f"meets them with probability {_g(s['evidence'])} [95 %: {_g(lo)}, {_g(hi)}] "
            f"(stage A, {s['draws']:,} prior draws). Identified by the facts: "
            f"{', '.join(ident) if ident else 'none of the unknowns'}"
            + (f"; piled at a prior wall: {', '.join(walls)}" if walls else "")
            + ". The calibrated robot is robot.toml.")  # fmt: skip


def report_md(doc: dict[str, Any]) -> str:
    """The whole calibration as Markdown."""
    s = doc["structure"]
    out = [f"# {doc['title']}: the robot calibrated on what it did", "",
           f"Robot: {doc['robot']}; facts: `{doc.get('evidence_file', '?')}`"
           + (f"; every run capped at {doc['duration_cap']:g} s (a smoke test)"
              if doc.get("duration_cap") else "") + ".", "", headline(doc), "",
           "## The facts", "",
           "| fact | what | source | share of prior draws meeting it | rejects the "
           "structure |", "|---|---|---|---|---|"]  # fmt: skip
    rej = set(s["rejected_by"]) if s["rejected"] else set()
    for f in doc["facts"]:
        out.append(f"| `{f['name']}` | {f['what']} | {f['source'] or '-'} | "
                   f"{f['prior_share']:.3f} | {'yes' if f['name'] in rej else ''} |")
    out += ["", "A fact most prior twins meet says little about the unknowns; one few meet "
            "says much. A fact that rejects the structure is met by no twin together with the "
            "others (`conflicts` in calibration.json: the smallest sets that cannot be met "
            "together).", ""]  # fmt: skip
    out += ["## Twins searched", "",
            f"Stage A: {doc['stages']['A']:,} prior draws; stage B: {doc['stages']['B']:,} "
            "draws around the stage-A twins meeting the most facts (a search: it finds, it "
            f"does not weigh). Meeting every fact: {doc['consistent']:,}.", ""]  # fmt: skip
    if doc["marginals"]:
        out += ["## The unknowns, over the twins meeting every fact", "",
                "Unweighted: a description of the twins found. Identified: their 90 % range "
                "is narrower than half the prior's.", "",
                "| unknown | prior | 5 % | 50 % | 95 % | identified | at a wall |",
                "|---|---|---|---|---|---|---|"]  # fmt: skip
        for k, m in doc["marginals"].items():
            pr = f"{_g(m['prior'][0])}-{_g(m['prior'][1])}" + (" (log)" if m["scale"] == "log"
                                                               else "")  # fmt: skip
            out.append(f"| {k} | {pr} | {_g(m['q05'])} | {_g(m['q50'])} | {_g(m['q95'])} | "
                       f"{'yes' if m['identified'] else ''} | {m['wall'] or ''} |")
        out.append("")
    off = doc.get("offset")
    if off:
        out += [f"What the facts pin even where the marginals do not: {off['what']}, "
                f"{_g(off['q05'])} / {_g(off['q50'])} / {_g(off['q95'])} (5 / 50 / 95 %, over "
                "the twins meeting every fact; a complementary filter without gyro zeroing).",
                ""]  # fmt: skip
    if "member" in doc:
        m = doc["member"]
        out += ["## The calibrated robot (robot.toml)", "",
                f"Draw {m['sample']}: {m['how']}. Its `[prior]` is the robot file's: a "
                "declared prior is not narrowed by the facts it is judged on.", "",
                "| unknown | value |", "|---|---|"]  # fmt: skip
        out += [f"| {k} | {_g(v)} |" for k, v in m["values"].items()]
        out.append("")
    return "\n".join(out)
