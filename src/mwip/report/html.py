"""The HTML report ``OUT/index.html``: one self-contained page (figures embedded as PNG data
URIs, no scripts, no network), built from the results folder only.

Per study: the set-up, our figures beside a description of the book's, the published-vs-ours
table with relative differences, the claims with their verdicts and deciding numbers, the
explanation of the gaps, the runs and settings. At the top: an overview table and the run
metadata (mwip version, parameters, seeds, steps, wall times).
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
from typing import Any

from mwip.io import write_text_atomic
from mwip.report.results import StudyResult, load_results, load_run_record
from mwip.report.summary import format_number, is_book_claim

__all__ = ["render_html", "write_report"]

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0;color:#1d2329;
background:#f6f7f9;line-height:1.45}
main{max-width:1180px;margin:0 auto;padding:1.2rem 1.5rem 4rem}
h1{font-size:1.7rem;margin:.4rem 0}h2{font-size:1.3rem;margin:0 0 .3rem}
h3{font-size:1.02rem;margin:1rem 0 .3rem;color:#37424d}
section.study{background:#fff;border:1px solid #dde2e7;border-radius:8px;padding:1rem 1.2rem;
margin:1.2rem 0}
table{border-collapse:collapse;font-size:.9rem;margin:.3rem 0}
th,td{border-bottom:1px solid #e4e8ec;padding:.25rem .6rem;text-align:left;vertical-align:top}
th{background:#eef1f4}td.num{text-align:right;font-variant-numeric:tabular-nums}
.ok{color:#116b2b;font-weight:600;white-space:nowrap}
.no{color:#a3231a;font-weight:600;white-space:nowrap}
.badge{display:inline-block;border-radius:10px;padding:0 .55rem;font-size:.82rem;
background:#e8edf2}
.fail{background:#fbe3e1;border:1px solid #e9b3ad;padding:.5rem .8rem;border-radius:6px}
.grid{display:grid;grid-template-columns:minmax(0,2fr) minmax(0,1fr);gap:1rem}
figure{margin:.3rem 0}figure img{max-width:100%;border:1px solid #e4e8ec}
figcaption{font-size:.82rem;color:#56616c}
.book{background:#f3f6fa;border-left:4px solid #7b93ad;padding:.5rem .8rem;font-size:.92rem}
.muted{color:#56616c;font-size:.88rem}pre{background:#f3f5f7;padding:.5rem;overflow:auto;
font-size:.8rem}
nav a{margin-right:.6rem}
"""


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (
        f'<figure><img alt="{_e(path.stem)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{_e(path.name)}</figcaption></figure>"
    )


def _setting(v: Any) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(format_number(x) for x in v) + "]"
    return format_number(v)


def _verdict(holds: Any) -> str:
    return '<span class="ok">holds</span>' if holds else '<span class="no">does not hold</span>'


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
        '<table class="comparison"><tr><th>quantity</th><th>ours</th><th>published</th>'
        f"<th>relative difference</th></tr>{body}</table>"
    )


def _claims_table(res: StudyResult) -> str:
    if not res.claims:
        return '<p class="muted">No claims.</p>'
    body = ""
    for c in res.claims:
        values = c.get("values") or {}
        vals = ", ".join(f"{_e(k)} = {format_number(v)}" for k, v in values.items())
        kind = "book" if is_book_claim(c) else "ours"
        body += f"<tr><td>{kind}</td><td>{_e(c.get('text', ''))}</td>"
        body += f"<td>{_verdict(c.get('holds'))}</td>"
        body += f"<td class='muted'>{vals or '-'}</td></tr>"
    return (
        '<table class="claims"><tr><th>by</th><th>claim</th><th>verdict</th>'
        "<th>deciding numbers</th></tr>"
        f"{body}</table>"
    )


def _runs_table(doc: dict[str, Any]) -> str:
    runs = doc.get("runs", {})
    body = "".join(
        f"<tr><td>{_e(k)}</td><td>{_e(v.get('status'))}</td>"
        f"<td class='num'>{format_number(v.get('t_end'))}</td></tr>"
        for k, v in runs.items()
    )
    return f"<table><tr><th>run</th><th>status</th><th>t_end (s)</th></tr>{body}</table>"


def _study_section(res: StudyResult) -> str:
    info = res.info
    title = info.get("title", res.name)
    src = res.doc.get("source", "") if res.doc else ""
    parts = [f'<section class="study" id="{_e(res.name)}">']
    held, n = res.held
    parts.append(f"<h2>{_e(res.name)}: {_e(title)}</h2>")
    parts.append(
        f'<p class="muted">Book source: {_e(src)} &middot; claims holding: {held}/{n}'
        + (f" &middot; wall time {res.wall_s:.1f} s" if res.wall_s else "")
        + "</p>"
    )
    if res.error:
        extra = " Results below are from an earlier run." if res.doc else ""
        parts.append(f'<p class="fail">This study failed: {_e(res.error)}.{extra}</p>')
    if info.get("setup"):
        parts.append(f"<h3>Set-up</h3><p>{_e(info['setup'])}</p>")
    if res.settings:
        rows = "".join(
            f"<tr><td>{_e(k)}</td><td>{_e(_setting(v))}</td></tr>" for k, v in res.settings.items()
        )
        parts.append(
            "<details><summary>Study settings (its study file: "
            f"<code>mwip scenario {_e(res.name)}</code>)</summary>"
            f"<table><tr><th>setting</th><th>value</th></tr>{rows}</table></details>"
        )
    figs = "".join(_img(p) for p in res.figures) or '<p class="muted">No figure.</p>'
    book = info.get("book", "")
    parts.append(
        f'<div class="grid"><div><h3>Our figures</h3>{figs}</div>'
        f'<div><h3>The book</h3><div class="book">{_e(book) or "-"}</div></div></div>'
    )
    if res.doc:
        parts.append("<h3>Published vs ours</h3>" + _comparison_table(res))
        parts.append("<h3>Claims</h3>" + _claims_table(res))
    if info.get("gaps"):
        doc_ref = f" (details: {_e(info['docs'])})" if info.get("docs") else ""
        parts.append(f"<h3>Gaps explained</h3><p>{_e(info['gaps'])}{doc_ref}</p>")
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


def _metadata(record: dict[str, Any]) -> str:
    if not record:
        return '<p class="muted">No run record (run.json) in this folder.</p>'
    rows = [
        ("mwip version", record.get("mwip_version")),
        ("started (UTC)", record.get("started")),
        ("wall time", f"{record.get('wall_s', 0):.1f} s"),
        ("parallel jobs", record.get("jobs")),
        ("quick mode", record.get("quick")),
        ("Python / NumPy / SciPy", " / ".join(str(record.get(k, "?")) for k in
                                             ("python", "numpy", "scipy"))),
        ("platform", record.get("platform")),
        ("command", record.get("command")),
    ]  # fmt: skip
    body = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows)
    return f"<table>{body}</table>" + _params_table(record)


def _overview(results: list[StudyResult]) -> str:
    body = ""
    for r in results:
        held, n = r.held
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
            f"<td class='num'>{held}/{n}</td><td>{_e(state)}</td><td>{_e(steps)}</td>"
            f"<td class='num'>{'-' if r.wall_s is None else f'{r.wall_s:.1f}'}</td></tr>"
        )
    return (
        "<table id='overview'><tr><th>study</th><th>book source</th><th>claims holding</th>"
        "<th>runs</th><th>steps / seed</th><th>wall (s)</th></tr>" + body + "</table>"
    )


def render_html(out: Path, names: list[str] | None = None) -> str:
    """The report page for the results folder ``out`` (a string)."""
    results = load_results(out, names)
    record = load_run_record(out)
    held = sum(r.held[0] for r in results)
    total = sum(r.held[1] for r in results)
    failed = [r.name for r in results if r.error]
    sections = "\n".join(_study_section(r) for r in results)
    nav = " ".join(f"<a href='#{_e(r.name)}'>{_e(r.name)}</a>" for r in results)
    verdict = f"{held} of {total} claims hold over {len(results)} studies"
    if failed:
        verdict += f"; failed: {', '.join(failed)}"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>mwip: reproduction report</title><style>{_CSS}</style></head>
<body><main>
<h1>mwip: reproduction of the book's studies</h1>
<p><span class="badge" id="verdict">{_e(verdict)}</span></p>
<p class="muted">Every verdict and number below is read from the studies' metrics.json files
(SPEC.md section 6). Figures are in the book's layout; the text beside each describes the
book's figure for comparison.</p>
<nav>{nav}</nav>
<h2 style="margin-top:1rem">Overview</h2>{_overview(results)}
<h2 style="margin-top:1rem">Run</h2>{_metadata(record)}
{sections}
</main></body></html>
"""


def write_report(out: Path, names: list[str] | None = None) -> Path:
    """Write ``out/index.html`` atomically; returns its path."""
    path = Path(out) / "index.html"
    write_text_atomic(path, render_html(out, names))
    return path
