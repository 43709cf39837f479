"""The HTML report ``OUT/index.html``: one page (figures embedded as PNG data URIs, each a
link to its full-size file in ``OUT``; no scripts, no network), built from the results folder
only.

It leads with the book: the headline is how many of the book's claims reproduce; the first
section is the table of the book's claims, those that reproduce first, then those that do not,
grouped by cause (:data:`mwip.schema.claims.CAUSES`) with their evidence, each with its
verdict under the other damping reading where a comparison folder is given
(:mod:`mwip.report.claims`). Our extra claims are counted separately. Then an overview table,
the run metadata, and per study: the set-up, the book's figure described, our figures and a
poster frame of the main run, the published-vs-ours table, the claims, the gaps, the runs.

Figures are shown at their natural width where the page allows (the study figures are drawn
at most 1440 px wide, so at 1280 px the page shrinks them by at most about 1.2x); a click
opens the full-size file.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mwip.io import html_text, write_text_atomic
from mwip.report.claims import (
    CAUSES,
    NO_CAUSE,
    Comparison,
    book_claims,
    counts,
    find_compare,
    is_book,
    load_comparison,
)
from mwip.report.posters import POSTER_DIR, ensure_posters
from mwip.report.results import StudyResult, load_results, load_run_record
from mwip.report.summary import format_number, headline
from mwip.report.verdict import ACROSS, Verdict

__all__ = ["render_html", "write_report", "runs_outcome", "twin_headline"]

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0;color:#1d2329;
background:#f6f7f9;line-height:1.45;font-size:16px}
main{max-width:1280px;margin:0 auto;padding:1rem 1.2rem 4rem;box-sizing:border-box}
h1{font-size:1.6rem;margin:.4rem 0}h2{font-size:1.3rem;margin:1.2rem 0 .3rem}
h3{font-size:1.05rem;margin:1rem 0 .3rem;color:#37424d}
.headline{font-size:1.45rem;font-weight:700;margin:.3rem 0;color:#123}
.subhead{font-size:1.05rem;font-weight:600;margin:.2rem 0 .5rem;color:#234}
section.study{background:#fff;border:1px solid #dde2e7;border-radius:8px;padding:1rem;
margin:1.2rem 0}
.scroll{overflow-x:auto}
table{border-collapse:collapse;font-size:.92rem;margin:.3rem 0}
th,td{border-bottom:1px solid #e4e8ec;padding:.25rem .5rem;text-align:left;vertical-align:top}
th{background:#eef1f4}td.num{text-align:right;font-variant-numeric:tabular-nums}
tr.group th{background:#dfe6ee;font-size:.95rem}
tr.group.holds th{background:#e1f0e4}
.ok{color:#116b2b;font-weight:600;white-space:nowrap}
.no{color:#a3231a;font-weight:600;white-space:nowrap}
.na{color:#56616c;white-space:nowrap}
.badge{display:inline-block;border-radius:10px;padding:0 .55rem;font-size:.88rem;
background:#e8edf2}
.fail{background:#fbe3e1;border:1px solid #e9b3ad;padding:.5rem .8rem;border-radius:6px}
figure{margin:.5rem 0}figure img{max-width:100%;height:auto;border:1px solid #e4e8ec;
display:block}
figcaption{font-size:.88rem;color:#56616c}
.book{background:#f3f6fa;border-left:4px solid #7b93ad;padding:.5rem .8rem;font-size:.95rem}
.muted{color:#56616c;font-size:.92rem}pre{background:#f3f5f7;padding:.5rem;overflow:auto;
font-size:.85rem}
nav a{margin-right:.6rem;white-space:nowrap}
code{font-size:.9em}
table.bookclaims td:first-child,table.claims td:first-child{white-space:nowrap}
table.bookclaims td:nth-child(2),table.claims td:nth-child(2){min-width:16rem}
@media (max-width:700px){main{padding:.6rem}
table.bookclaims thead,table.claims tr.head{display:none}
table.bookclaims,table.bookclaims tbody,table.bookclaims tr,table.bookclaims td,
table.bookclaims th,table.claims,table.claims tbody,table.claims tr,table.claims td
{display:block;width:auto;min-width:0!important}
table.bookclaims tr,table.claims tr{border-bottom:1px solid #cfd6dd;padding:.3rem 0}
table.bookclaims td,table.claims td{border:none;padding:.1rem .4rem;white-space:normal}
td[data-label]::before{content:attr(data-label) ": ";font-weight:600;color:#56616c}}
"""


#: Where `mwip report` looks for a claims campaign by default (inside the results folder).
CLAIMS_CAMPAIGN = "claims-campaign"


def _e(x: Any) -> str:
    return html_text(x)


def _img(path: Path, href: str, caption: str | None = None) -> str:
    """A figure shown at its natural width (at most the page's), linking to the full file.
    The image is the file itself (``href``, relative to the report), not a copy embedded in
    the page: the report stays small (issue 25: under 1 MB) and the folder is the unit to
    copy."""
    cap = caption if caption is not None else _e(path.name)
    return (
        f'<figure><a href="{_e(href)}" target="_blank" title="open the full-size image">'
        f'<img alt="{_e(path.stem)}" src="{_e(href)}"></a>'
        f"<figcaption>{cap} &middot; click for full size</figcaption></figure>"
    )


def _setting(v: Any) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(format_number(x) for x in v) + "]"
    return format_number(v)


def _verdict(holds: Any) -> str:
    if holds is None:
        return '<span class="na">not run</span>'
    return '<span class="ok">holds</span>' if holds else '<span class="no">does not hold</span>'


def _one_verdict(v: Verdict) -> str:
    """A claim's one verdict (:func:`mwip.report.verdict.claim_verdict`): across the twins
    for a Chapter 6 claim judged there, with this run's result beside it as a value."""
    if not v.across:
        return _verdict(v.held)
    cls = "ok" if v.held else ("no" if v.label == "fails" else "na")
    beside = f"across twins; this run's twin: {str(v.this_run).lower()}"
    return f'<span class="{cls}">{_e(v.label)}</span> <span class="muted">{_e(beside)}</span>'


def _comparison_table(res: StudyResult) -> str:
    rows = res.comparison()
    if not rows:
        return '<p class="muted">The book prints no numbers for this study.</p>'
    body = "".join(
        f"<tr><td>{_e(k)}</td><td class='num'>{format_number(o)}</td>"
        f"<td class='num'>{format_number(p)}</td>"
        f"<td class='num'>{'-' if d is None else f'{100 * d:+.1f} %'}</td></tr>"
        for k, o, p, d in rows
    )
    return (
        '<div class="scroll"><table class="comparison"><tr><th>quantity</th><th>ours</th>'
        f"<th>published</th><th>relative difference</th></tr>{body}</table></div>"
    )


def _values(c: dict[str, Any]) -> str:
    values = c.get("values") or {}
    return ", ".join(f"{_e(k)} = {format_number(v)}" for k, v in values.items())


def _why(c: dict[str, Any], seen: set[str] | None = None) -> str:
    """Evidence (with the deciding numbers) for a failing book claim; the numbers otherwise.
    ``seen``: the evidence texts already shown in this table for the same study; a repeat is
    shown once (issue 25: the same paragraph six times per study), later rows refer to it."""
    parts = []
    ev = c.get("evidence")
    if ev and seen is not None and ev in seen:
        parts.append('<span class="muted">(the same evidence as above)</span>')
    elif ev:
        parts.append(_e(ev))
        if seen is not None:
            seen.add(ev)
    vals = _values(c)
    if vals:
        parts.append(f'<span class="muted">{vals}</span>')
    return "<br>".join(parts) or "-"


#: ``note(study, claim) -> str``: the claims campaign's "holds in X % of plausible settings"
Note = Callable[[str, dict[str, Any]], str]


def _no_note(study: str, claim: dict[str, Any]) -> str:
    return ""


def claim_robustness_note(folder: Path | None) -> Note:
    """The note shown beside each claim from a finished ``claims`` campaign in ``folder``
    (``mwip campaign run claims --out OUT/claims-campaign``; issue 15), or no note."""
    if folder is None or not (Path(folder) / "results.parquet").is_file():
        return _no_note
    from mwip.schema.robustness import load_claim_robustness, robustness_text

    table = load_claim_robustness(folder)
    return lambda study, claim: robustness_text(table, study, claim)


def _robust(note: Note, study: str, c: dict[str, Any]) -> str:
    text = note(study, c)
    return f'<br><span class="muted">{_e(text)}</span>' if text else ""


def _claims_table(res: StudyResult, compare: Comparison | None, note: Note = _no_note) -> str:
    if not res.claims:
        return '<p class="muted">No claims.</p>'
    other = f"<th>{_e(compare.label)}</th>" if compare else ""
    body = ""
    seen: set[str] = set()
    for c in res.claims:
        kind = "book" if is_book(c) else "ours"
        v = res.verdict(c)
        cause = _e(c.get("cause", "")) if is_book(c) and not v.held else ""
        body += f"<tr><td data-label='by'>{kind}</td><td>{_e(c.get('text', ''))}</td>"
        body += (f"<td data-label='verdict'>{_one_verdict(v)}"
                 f"{_robust(note, res.name, c)}</td>")  # fmt: skip
        body += f"<td data-label='cause'>{cause or '-'}</td>"
        if compare:
            body += (f"<td data-label='{_e(compare.label)}'>"
                     f"{_verdict(compare.verdict(res.name, c))}</td>")  # fmt: skip
        body += f"<td data-label='evidence'>{_why(c, seen)}</td></tr>"
    return (
        '<div class="scroll"><table class="claims"><tr class="head"><th>by</th><th>claim</th>'
        f"<th>verdict</th><th>cause</th>{other}<th>evidence and deciding numbers</th></tr>"
        f"{body}</table></div>"
    )


def _book_claims_section(
    results: list[StudyResult], damping: str | None, compare: Comparison | None,
    note: Note = _no_note,
) -> str:  # fmt: skip
    """The first section: every book claim, those that reproduce, then by cause."""
    claims = book_claims(results)
    if not claims:
        return (
            '<section id="book-claims"><h2>The book\'s claims</h2><p class="muted">No study '
            'in this folder marks a claim as the book\'s (<code>"book": true</code>).</p>'
            "</section>"
        )
    here = f"here ({_e(damping)} reading)" if damping else "here"
    other = f"<th>{_e(compare.label)}</th>" if compare else ""
    ncol = 4 + bool(compare)

    seen: dict[str, set[str]] = {}  # per study: evidence texts shown in this table

    def row(r: StudyResult, c: dict[str, Any]) -> str:
        cells = (
            f"<tr><td><a href='#{_e(r.name)}'>{_e(r.name)}</a></td><td>{_e(c.get('text', ''))}"
            f"</td><td data-label='{here}'>{_one_verdict(r.verdict(c))}"
            f"{_robust(note, r.name, c)}</td>"
        )
        if compare:
            cells += (f"<td data-label='{_e(compare.label)}'>"
                      f"{_verdict(compare.verdict(r.name, c))}</td>")  # fmt: skip
        why = _why(c, seen.setdefault(r.name, set()))
        return cells + f"<td data-label='evidence'>{why}</td></tr>"

    held = [(r, c) for r, c in claims if r.verdict(c).held]
    body = (
        f"<tbody class='holds'><tr class='group holds'><th colspan='{ncol}'>Reproduces: "
        f"{len(held)}</th></tr>" + "".join(row(r, c) for r, c in held) + "</tbody>"
    )
    failing = [(r, c) for r, c in claims if not r.verdict(c).held]
    groups: dict[str, list[tuple[StudyResult, dict[str, Any]]]] = {}
    for r, c in failing:
        v = r.verdict(c)
        cause = c.get("cause") if c.get("cause") in CAUSES else (
            c.get("cause") or (f"{v.label} across twins" if v.across else NO_CAUSE))
        groups.setdefault(str(cause), []).append((r, c))
    order = [k for k in CAUSES if k in groups] + [k for k in groups if k not in CAUSES]
    for cause in order:
        rows = groups[cause]
        what = CAUSES.get(cause, "the study records no cause" if cause == NO_CAUSE else
                          "the verdict across the calibration's twins (the identified twin "
                          "section)" if cause.endswith("across twins") else "")
        body += (
            f"<tbody class='cause' data-cause='{_e(cause)}'><tr class='group'><th "
            f"colspan='{ncol}'>Does not reproduce: {_e(cause)} ({len(rows)})"
            f"{' &mdash; ' + _e(what) if what else ''}</th></tr>"
            + "".join(row(r, c) for r, c in rows)
            + "</tbody>"
        )
    return (
        '<section id="book-claims"><h2>The book\'s claims</h2>'
        f'<p class="muted">{len(claims)} claims the book makes, judged by its own words. '
        "A claim that does not reproduce is grouped by its cause; the evidence gives our "
        "numbers. A Chapter 6 claim that the calibration judges across the posterior's twins "
        "has that one verdict (holds, fails, undecided); this run's result on the default twin "
        "is the value beside it (the identified twin section)."
        + (
            f" The column <em>{_e(compare.label)}</em> is the verdict of the same claim in "
            f"<code>{_e(compare.folder.name)}/</code>, the run under the other reading of the "
            "tables' damping (SPEC.md section 2)."
            if compare
            else ""
        )
        + "</p>"
        '<div class="scroll"><table class="bookclaims"><thead><tr><th>study</th><th>claim</th>'
        f"<th>{here}</th>{other}<th>evidence and deciding numbers</th></tr></thead>"
        f"{body}</table></div></section>"
    )


def runs_outcome(doc: dict[str, Any]) -> str:
    """One sentence on how this run's runs ended, generated from the runs table of
    ``metrics.json`` (``runs``: status and end time of each), so that the words beside the
    table cannot contradict it: ``"All 6 runs stand for their whole duration (10 s)."`` or
    ``"4 of 6 runs stand for their whole duration; fell: smc.case2 at 0.53 s, ..."``."""
    runs = {k: v for k, v in (doc.get("runs") or {}).items() if isinstance(v, dict)}
    if not runs:
        return ""
    ok = [k for k, v in runs.items() if v.get("status") == "ok"]
    ends = sorted({format_number(runs[k].get("t_end")) for k in ok})
    span = f" ({ends[0]} s)" if len(ends) == 1 and ends[0] != "n/a" else ""
    if len(ok) == len(runs):
        n = len(runs)
        return (f"All {n} runs stand for their whole duration{span}." if n > 1
                else f"The run stands for its whole duration{span}.")
    others = []
    for status in sorted({str(v.get("status")) for k, v in runs.items() if k not in ok}):
        which = [f"{k} at {format_number(v.get('t_end'))} s" for k, v in runs.items()
                 if str(v.get("status")) == status]  # fmt: skip
        others.append(f"{status}: {', '.join(which)}")
    head = (f"{len(ok)} of {len(runs)} runs stand for their whole duration{span}" if ok
            else f"None of the {len(runs)} runs stands for its whole duration")
    return f"{head}; {'; '.join(others)}."


def _runs_table(doc: dict[str, Any]) -> str:
    runs = doc.get("runs", {})
    body = "".join(
        f"<tr><td>{_e(k)}</td><td>{_e(v.get('status'))}</td>"
        f"<td class='num'>{format_number(v.get('t_end'))}</td></tr>"
        for k, v in runs.items()
    )
    return f"<table><tr><th>run</th><th>status</th><th>t_end (s)</th></tr>{body}</table>"


def _poster(res: StudyResult) -> str:
    folder = res.folder / POSTER_DIR
    posters = sorted(folder.glob("*.png")) if folder.is_dir() else []
    if not posters:
        return ""
    p = posters[0]
    run = p.stem
    cap = (
        f"main run <code>{_e(run)}</code> at its end, drawn to scale; animate it: "
        f"<code>mwip animate OUT/{_e(res.name)} --run {_e(run)}</code>"
    )
    return "<h3>The robot</h3>" + _img(p, f"{res.name}/{POSTER_DIR}/{p.name}", cap)


def _ablation(res: StudyResult) -> str:
    """The study's twin ablation (issue 16): the ideal robot, then each physical element of
    the digital twin added in turn, with the book's claims judged at every step (the table
    the study wrote, named in ``settings.ablation_table``)."""
    field = (res.doc or {}).get("settings", {}).get("ablation_table") or {}
    name = field.get("html") if isinstance(field, dict) else None
    path = res.folder / str(name) if name else None
    if path is None or not path.is_file() or path.parent != res.folder:
        return ""
    return (
        "<h3>Which physical effect decides: the twin's ablation</h3>"
        '<p class="muted">From the ideal robot (Table 6.1 with ideal sensors and drive), each '
        "element of the digital twin added in turn (docs/twin_model.md): "
        "the quantity per run, and the book's claims judged at every step.</p>"
        f'<div class="scroll ablation">{path.read_text(encoding="utf-8")}</div>'
    )


def twin_headline(record: dict[str, Any]) -> str:
    """One sentence on the twin the Chapter 6 studies ran on (the run record's
    ``twin_status``, :func:`mwip.hardware.identified.status`), or ``""``."""
    st = record.get("twin_status")
    if not isinstance(st, dict) or not st.get("text"):
        return ""
    c = st.get("claim_counts") or {}
    if not st.get("identified"):
        return f"Chapter 6 ran on {st['text']}."
    return (f"Chapter 6, judged across the identified twins: {c.get('holds', 0)} held-out "
            f"claims hold, {c.get('fails', 0)} fail, {c.get('undecided', 0)} undecided; "
            f"{st['text']}.")  # fmt: skip


def _pct(x: Any) -> str:
    return "n/a" if not isinstance(x, int | float) else f"{100 * x:.0f} %"


def _twin_headline_html(record: dict[str, Any]) -> str:
    text = twin_headline(record)
    return f'<p class="subhead" id="twin-headline">{_e(text)}</p>' if text else ""


def _identified_section(record: dict[str, Any], results: Sequence[StudyResult] = ()) -> str:
    """The identified twin: where it comes from and the held-out Chapter 6 claims across the
    posterior (``mwip twin calibrate book --record``, docs/book_calibration). The verdict
    column is each claim's one verdict; the default twin's column is a value: this run's
    result where the study ran (``true``/``false``), else the calibration's."""
    st = record.get("twin_status")
    if not isinstance(st, dict) or not st.get("identified"):
        return ""
    ran = {(r.name, str(c.get("id"))): r.verdict(c).this_run for r in results
           for c in r.claims if c.get("id")}  # fmt: skip
    rows = []
    for cl in st.get("claims") or []:
        iv = cl.get("interval") or [None, None]
        by = cl.get("decided_by") or {}
        val = ran.get((str(cl.get("study")), str(cl.get("id"))), cl.get("default_twin"))
        dflt = "n/a" if val is None else str(bool(val)).lower()
        rows.append(
            f"<tr><td>{_e(cl.get('study'))}</td><td>{_e(cl.get('text'))}</td>"
            f"<td class='num'>{_pct(cl.get('fraction'))} ({_pct(iv[0])}-{_pct(iv[1])})</td>"
            f"<td>{_e(ACROSS.get(str(cl.get('verdict')), cl.get('verdict')))}</td><td>{dflt}</td>"
            f"<td>{_e(by.get('parameter', ''))}</td></tr>"
        )  # fmt: skip
    dropped = st.get("dropped") or []
    return (
        '<section id="identified-twin"><h2>The identified twin</h2>'
        f"<p>{_e(st['text'][0].upper() + st['text'][1:])}.</p>"
        '<p class="muted">The twin\'s unknowns (gear ratio, back-EMF compensation, dead-band, '
        "friction, sensors, payload geometry) were identified from the book's calibration "
        "evidence only (every Chapter 6 run stands; Table 6.4's Case 1 SMC numbers), declared "
        "before the fit in <code>mwip/calibration/book-evidence.toml</code> (the twin "
        "structures compared in <code>book-structures.toml</code>); the claims below "
        "are judged on evidence the fit never used, on the twins' measured signals (the "
        "board's pitch estimate, the encoder speeds). A claim holds or fails when it does in "
        "at least 95 % of the consistent twins, else it is undecided (the parameter that "
        "decides it is named)."
        + (" Calibration facts no twin met together with the others (dropped): "
           f"{_e(', '.join(dropped))}." if dropped
           else "")
        + "</p>"
        '<div class="scroll"><table><tr><th>study</th><th>claim</th><th>holds in (95 % CI)</th>'
        "<th>verdict</th><th>this run on the default twin (a value)</th><th>decided by</th></tr>"
        + "".join(rows) + "</table></div></section>"
    )  # fmt: skip


#: Units of the twin's sensitivity tables' columns (issue 25: tables without units).
_UNITS = {"mass": "kg", "rod_height": "m", "body_height": "m", "mb": "kg", "l": "m",
          "Iby": "kg m^2", "Gb": "N m/rad", "Gb_over_nominal": "-", "pitch_pole": "1/s",
          "height": "m", "climb_angle": "rad", "duration": "s", "torque": "N m",
          "impulse": "N m s", "work": "J"}  # fmt: skip


def _unit(key: str) -> str:
    u = _UNITS.get(key)
    return f" [{u}]" if u else ""


def _twin_section(results: list[StudyResult], record: dict[str, Any]) -> str:
    """The digital twin's assumptions where the book prints none: the Case 2 payload and the
    Case 3 stick, as sensitivities of the robot that ran (issue 16 item 3)."""
    if not any(_ablation(r) for r in results):
        return ""
    from mwip.hardware.sensitivity import payload_sensitivity, stick_sensitivity
    from mwip.params import REAL, Params

    try:
        base = Params.from_dict(record["params"]["plant"])
    except (KeyError, TypeError, ValueError):
        base = REAL

    def table(rows: list[dict[str, Any]]) -> str:
        head = "".join(f"<th>{_e(k)}{_e(_unit(k))}</th>" for k in rows[0])
        body = "".join(
            "<tr>" + "".join(f"<td class='num'>{format_number(v)}</td>" for v in r.values())
            + "</tr>" for r in rows
        )  # fmt: skip
        return f'<div class="scroll"><table><tr>{head}</tr>{body}</table></div>'

    return (
        '<section id="twin"><h2>The digital twin: assumptions the book does not print</h2>'
        '<p class="muted">Case 2: a pan of mass m on rods above the body (mass, rod height '
        "and the body's own height are assumptions: <code>Params.with_payload</code>); Case 3: "
        "a stick of the given height crossed at -7 rad/s (<code>mwip.hardware.obstacle</code>). "
        "The tables give how the robot's pitch dynamics (gravity term against the design "
        "model's, pitch pole) and the bump depend on them; the closed-loop sensitivities and "
        "the gear-ratio table are in docs/twin_model.md and <code>mwip twin sensitivity</code>."
        "</p><h3>Payload (Case 2)</h3>"
        + table(payload_sensitivity(base=base))
        + "<h3>Stick (Case 3)</h3>"
        + table(stick_sensitivity(plant=base.with_payload()))
        + "</section>"
    )


def _twin_in_use(res: StudyResult) -> str:
    """The twin this run used, generated from its recorded settings (``settings.twin``,
    :func:`mwip.studies.twin_settings.twin_doc`): the set-up describes the robot in use."""
    tw = (res.doc or {}).get("settings", {}).get("twin")
    return f"<p><b>The twin of this run:</b> {_e(tw)}</p>" if isinstance(tw, str) and tw else ""


def _study_section(res: StudyResult, compare: Comparison | None, note: Note = _no_note) -> str:
    info = res.info
    title = info.get("title", res.name)
    src = res.doc.get("source", "") if res.doc else ""
    parts = [f'<section class="study" id="{_e(res.name)}">']
    book = [c for c in res.claims if is_book(c)]
    hb = sum(res.verdict(c).held for c in book)
    extra = [c for c in res.claims if not is_book(c)]
    he = sum(res.verdict(c).held for c in extra)
    on = f" (on {res.robot})" if res.robot else ""  # not the book's robot (run.json)
    parts.append(f"<h2>{_e(res.name)}: {_e(title)}{_e(on)}</h2>")
    parts.append(
        f'<p class="muted">Book source: {_e(src)} &middot; book claims reproducing: {hb}/'
        f"{len(book)} &middot; extras of ours holding: {he}/{len(extra)}"
        + (f" &middot; wall time {res.wall_s:.1f} s" if res.wall_s else "")
        + "</p>"
    )
    if res.error:
        extra_note = " Results below are from an earlier run." if res.doc else ""
        parts.append(f'<p class="fail">This study failed: {_e(res.error)}.{extra_note}</p>')
    if info.get("setup"):
        parts.append(f"<h3>Set-up</h3><p>{_e(info['setup'])}</p>" + _twin_in_use(res))
    if res.settings:
        rows = "".join(
            f"<tr><td>{_e(k)}</td><td>{_e(_setting(v))}</td></tr>" for k, v in res.settings.items()
        )
        parts.append(
            "<details><summary>Study settings (its study file: "
            f"<code>mwip scenario {_e(res.name)}</code>)</summary>"
            f"<table><tr><th>setting</th><th>value</th></tr>{rows}</table></details>"
        )
    if res.doc:
        parts.append("<h3>Claims</h3>" + _claims_table(res, compare, note))
    book_text = info.get("book", "")
    parts.append(f'<h3>The book</h3><div class="book">{_e(book_text) or "-"}</div>')
    figs = "".join(_img(p, f"{res.name}/{p.name}") for p in res.figures)
    parts.append("<h3>Our figures</h3>" + (figs or '<p class="muted">No figure.</p>'))
    parts.append(_poster(res))
    if res.doc:
        parts.append("<h3>Published vs ours</h3>" + _comparison_table(res))
        parts.append(_ablation(res))
    outcome = runs_outcome(res.doc) if res.doc else ""
    if info.get("gaps") or outcome:
        doc_ref = f" (details: {_e(info['docs'])})" if info.get("docs") else ""
        this = (f'<p class="outcome"><b>This run{_e(on)}:</b> {_e(outcome)} (the runs table '
                "below; generated from it)</p>") if outcome else ""  # fmt: skip
        gaps = f"<p>{_e(info['gaps'])}{doc_ref}</p>" if info.get("gaps") else ""
        parts.append(f"<h3>Gaps explained</h3>{this}{gaps}")
    if res.doc:
        settings = json.dumps(res.doc.get("settings", {}), indent=1, sort_keys=True)
        parts.append(
            "<details><summary>Runs and settings</summary>"
            f"{_runs_table(res.doc)}<pre>{_e(settings)}</pre></details>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def _params_table(record: dict[str, Any]) -> str:
    params = record.get("params", {})
    if not params:
        return ""
    names = list(params)
    keys = list(next(iter(params.values())))
    head = "".join(f"<th>{_e(n)}</th>" for n in names)
    body = "".join(
        f"<tr><td>{_e(k)}</td>"
        + "".join(f"<td class='num'>{format_number(params[n].get(k))}</td>" for n in names)
        + "</tr>"
        for k in keys
    )
    return f"<h3>Parameters</h3><table><tr><th>symbol</th>{head}</tr>{body}</table>"


def _metadata(record: dict[str, Any], compare: Comparison | None) -> str:
    if not record:
        return '<p class="muted">No run record (run.json) in this folder.</p>'
    rows = [
        ("mwip version", record.get("mwip_version")),
        ("started (UTC)", record.get("started")),
        ("wall time", f"{record.get('wall_s', 0):.1f} s"),
        ("parallel jobs", record.get("jobs")),
        ("quick mode", record.get("quick")),
        ("damping reading", record.get("damping", "not recorded")),
        ("compared with", f"{compare.folder.name}/ ({compare.label})" if compare else "-"),
        ("Python / NumPy / SciPy", " / ".join(str(record.get(k, "?")) for k in
                                             ("python", "numpy", "scipy"))),
        ("platform", record.get("platform")),
        ("command", record.get("command")),
    ]  # fmt: skip
    body = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows)
    return f"<div class='scroll'><table>{body}</table>{_params_table(record)}</div>"


def _overview(results: list[StudyResult]) -> str:
    body = ""
    for r in results:
        book = [c for c in r.claims if is_book(c)]
        hb = sum(r.verdict(c).held for c in book)
        extra = [c for c in r.claims if not is_book(c)]
        he = sum(r.verdict(c).held for c in extra)
        statuses = sorted({str(v.get("status")) for v in (r.doc or {}).get("runs", {}).values()})
        state = "failed" if r.error else ", ".join(statuses) or "-"
        steps = ""
        if r.doc:
            s = r.doc.get("settings", {})
            steps = ", ".join(f"{k} {format_number(s[k])}" for k in ("Ts", "dt", "seed")
                              if k in s and not isinstance(s[k], dict))  # fmt: skip
        body += (
            f"<tr><td><a href='#{_e(r.name)}'>{_e(r.name)}</a></td>"
            f"<td>{_e(r.doc.get('source', '') if r.doc else '')}</td>"
            f"<td class='num'>{hb}/{len(book)}</td><td class='num'>{he}/{len(extra)}</td>"
            f"<td>{_e(state)}</td><td>{_e(steps)}</td>"
            f"<td class='num'>{'-' if r.wall_s is None else f'{r.wall_s:.1f}'}</td></tr>"
        )
    return (
        "<div class='scroll'><table id='overview'><tr><th>study</th><th>book source</th>"
        "<th>book claims</th><th>extras</th><th>runs</th><th>steps / seed</th><th>wall (s)</th>"
        "</tr>" + body + "</table></div>"
    )


def render_html(
    out: Path, names: list[str] | None = None, compare: Path | None = None,
    claims_campaign: Path | None = None,
) -> str:  # fmt: skip
    """The report page for the results folder ``out`` (a string); ``compare`` is a second
    results folder (another damping reading) whose verdicts are shown beside;
    ``claims_campaign`` a finished ``claims`` campaign whose "holds in X % of plausible
    settings" is shown under each claim's verdict."""
    note = claim_robustness_note(claims_campaign)
    results = load_results(out, names)
    record = load_run_record(out)
    damping = record.get("damping")
    cmp = load_comparison(compare) if compare is not None else None
    n = counts(results)
    failed = [r.name for r in results if r.error]
    sections = "\n".join(_study_section(r, cmp, note) for r in results)
    nav = " ".join(f"<a href='#{_e(r.name)}'>{_e(r.name)}</a>" for r in results)
    extras = (
        f"Extras of ours (checks the book does not make), counted separately: "
        f"{n['extra_held']} of {n['extra']} hold"
        + (
            f" ({n['unlabelled']} claims carry no <code>book</code> field and are counted here)"
            if n["unlabelled"]
            else ""
        )  # fmt: skip
        + f". {len(results)} studies"
        + (f"; failed: {_e(', '.join(failed))}" if failed else "")
        + "."
    )
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>mwip: reproduction report</title><style>{_CSS}</style></head>
<body><main>
<h1>mwip: reproduction of the book's studies</h1>
<p class="headline" id="headline">{_e(headline(results, damping, cmp))}</p>
{_twin_headline_html(record)}
<p class="muted" id="extras">{extras}</p>
<p class="muted" id="marks">"does not hold" (<code>[no]</code> in the terminal summary) means
our run contradicts the book's claim as the book words it; its cause says why, its evidence
gives our numbers. Every verdict and number is read from the studies' metrics.json files
(SPEC.md section 6).</p>
<nav><a href="#book-claims">the book's claims</a> <a href="#overview">overview</a> {nav}</nav>
{_book_claims_section(results, damping, cmp, note)}
<h2>Overview</h2>{_overview(results)}
<h2>Run</h2>{_metadata(record, cmp)}
{_identified_section(record, results)}
{_twin_section(results, record)}
{sections}
</main></body></html>
"""


def write_report(
    out: Path, names: list[str] | None = None, compare: Path | None = None,
    claims_campaign: Path | None = None,
) -> Path:  # fmt: skip
    """Write ``out/index.html`` atomically (first the poster frame of each study's main run,
    where missing: :func:`mwip.report.posters.ensure_posters`); returns its path.

    ``compare``: the results folder of the other damping reading (default: ``OUT/compare-*``
    if there is one, :func:`mwip.report.claims.find_compare`). ``claims_campaign``: a
    finished ``claims`` campaign (default: ``OUT/claims-campaign`` if it has results).
    """
    out = Path(out)
    ensure_posters(load_results(out, names))
    if compare is None:
        compare = find_compare(out)
    if claims_campaign is None and (out / CLAIMS_CAMPAIGN / "results.parquet").is_file():
        claims_campaign = out / CLAIMS_CAMPAIGN
    path = out / "index.html"
    write_text_atomic(path, render_html(out, names, compare, claims_campaign))
    return path
