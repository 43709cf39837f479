"""The one-screen summary ``mwip reproduce`` ends with, read from each study's
``metrics.json``: first the headline (how many of the book's claims reproduce), one line
saying what the marks mean, then one line per study, for a study with a failing book claim
that claim with its cause and evidence, and last the extras of ours, counted separately.
Every claim is counted by its one verdict (:mod:`mwip.report.verdict`): a Chapter 6 claim
judged across the calibration's twins by that verdict, the run's own result beside it."""

from __future__ import annotations

import math
from typing import Any

from mwip.report.claims import Comparison, counts, is_book
from mwip.report.results import StudyResult
from mwip.report.verdict import Verdict

__all__ = ["MARKS", "across_count", "format_number", "headline", "summary_lines"]

#: What the marks mean, for a newcomer (printed under the headline).
MARKS = (
    "[ok]: all book claims of the study hold; [no]: one does not (first shown: [cause] evidence)"
)


def format_number(x: Any) -> str:
    """Compact number for tables: 4 significant digits; ``n/a`` for a missing value (stored as
    null in metrics.json: not finite, e.g. a settling time of a run that fell)."""
    if x is None:
        return "n/a"
    if isinstance(x, bool):
        return str(x).lower()
    if isinstance(x, int):
        return str(x)
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return str(v)
    return f"{v:.4g}"


def _clip(text: str, width: int) -> str:
    return text if len(text) <= width else text[: max(width - 3, 0)] + "..."


def _values(claim: dict[str, Any]) -> str:
    vals = claim.get("values") or {}
    return ", ".join(f"{k}={format_number(v)}" for k, v in vals.items())


def headline(results: list[StudyResult], damping: str | None = None,
             compare: Comparison | None = None) -> str:  # fmt: skip
    """``"Book claims: 18 of 42 reproduce (17 Chapter 6 claims judged across the calibration's
    twins: 1 holds, 14 fail, 2 undecided; damping reading units; literal reading: 12 of
    42)"``: each claim counted by its one verdict (:func:`across_count`)."""
    n = counts(results)
    text = f"Book claims: {n['book_held']} of {n['book']} reproduce"
    extra = [across_count(n)] if n["across"] else []
    extra += [f"damping reading {damping}"] if damping else []
    if compare is not None:
        other = [
            compare.verdict(r.name, c) for r in results for c in r.claims if is_book(c)
        ]  # fmt: skip
        known = [v for v in other if v is not None]
        extra.append(f"{compare.label}: {sum(known)} of {len(known)}")
    return text + (f" ({'; '.join(extra)})" if extra else "")


def across_count(n: dict[str, int]) -> str:
    """``"17 Chapter 6 claims judged across the calibration's twins: 1 holds, 14 fail, 2
    undecided"`` from :func:`mwip.report.claims.counts`."""
    words = {"holds": ("holds", "hold"), "fails": ("fails", "fail")}
    parts = []
    for label in ("holds", "fails", "undecided", "not judgeable"):
        k = n.get(f"across:{label}", 0)
        if k:
            one, many = words.get(label, (label, label))
            parts.append(f"{k} {one if k == 1 else many}")
    parts += [f"{v} {k[7:]}" for k, v in n.items() if k.startswith("across:") and v and
              k[7:] not in ("holds", "fails", "undecided", "not judgeable")]  # fmt: skip
    return (f"{n['across']} Chapter 6 claim{'s' if n['across'] != 1 else ''} judged across "
            f"the calibration's twins: {', '.join(parts)}")


def _mark(v: Verdict) -> str:
    """``[ok]`` for a claim counted as reproducing, ``[no]`` otherwise (undecided too)."""
    return "[ok]" if v.held else "[no]"


def _run_value(v: Verdict, label: bool = True) -> str:
    """The run's own result beside an across-twins verdict: a value, not a second verdict
    (``label``: the verdict's words first)."""
    if not v.across:
        return ""
    head = f"across twins: {v.label}; " if label else ""
    return f" ({head}this run's twin: {str(v.this_run).lower()})"


def _claim_line(c: dict[str, Any], width: int, indent: str,
                compare: Comparison | None, study: str,
                verdict: Verdict) -> list[str]:  # fmt: skip
    """A claim of the verbose summary: its mark and full text, then its deciding numbers
    ``<key=value, ...>`` and the other reading's verdict, wrapped to ``width`` (never cut),
    then for a failing book claim its cause and evidence."""
    import textwrap

    mark = _mark(verdict)
    kind = "" if is_book(c) else "(ours) "
    vals = f"  <{_values(c)}>" if c.get("values") else ""
    other = ""
    if compare is not None and (v := compare.verdict(study, c)) is not None:
        other = f" [{compare.damping or 'other'}: {'ok' if v else 'no'}]"
    text = f"{mark} {kind}{c.get('text', '')}{_run_value(verdict)}{vals}{other}"
    lines = textwrap.wrap(text, width=max(width, 40), initial_indent=indent,
                          subsequent_indent=indent + "     ", break_on_hyphens=False,
                          drop_whitespace=True, replace_whitespace=False)  # fmt: skip
    if is_book(c) and not verdict.held:
        lines += _why(c, width, indent + "     ", wrap=True)
    return lines


def _why(c: dict[str, Any], width: int, indent: str, wrap: bool = False) -> list[str]:
    """One line: ``[cause] evidence`` (the deciding numbers where there is no evidence);
    ``wrap``: all of it, wrapped to ``width``."""
    import textwrap

    cause = f"[{c['cause']}] " if c.get("cause") else ""
    why = c.get("evidence") or _values(c)
    if not (cause or why):
        return []
    if wrap:
        return textwrap.wrap(f"{cause}{why}", width=max(width, 40), initial_indent=indent,
                             subsequent_indent=indent, break_on_hyphens=False)  # fmt: skip
    return [_clip(f"{indent}{cause}{why}", width)]


def summary_lines(
    results: list[StudyResult],
    width: int = 100,
    verbose: bool = False,
    *,
    damping: str | None = None,
    compare: Comparison | None = None,
) -> list[str]:
    """The summary, from each study's ``metrics.json`` (see module docstring).

    Default (one screen): the headline, the marks, per study one line - ``[ok]`` when every
    book claim holds - with its book claims holding, the extras holding and the run statuses,
    then the first failing book claim with its cause and evidence. ``verbose``: every claim.
    ``damping`` names this run's reading; ``compare`` adds the verdicts of the other one.
    """
    # the headline is never cut (the terminal wraps it): its counts are the run's verdicts
    lines = [headline(results, damping, compare), _clip(MARKS, width)]
    for res in results:
        src = res.doc.get("source", "") if res.doc else res.info.get("source", "")
        if res.doc is None:
            lines.append(_clip(f"[!!] {res.name} ({src}): FAILED - {res.error}", width))
            continue
        claims = res.claims
        book = [c for c in claims if is_book(c)]
        extra = [c for c in claims if not is_book(c)]
        hb = sum(res.verdict(c).held for c in book)
        he = sum(res.verdict(c).held for c in extra)
        runs = ", ".join(sorted({str(r.get("status")) for r in res.doc.get("runs", {}).values()}))
        mark = "[ok]" if hb == len(book) else "[no]"
        counted = f"book claims {hb}/{len(book)}" if book else "no book claim"
        head = f"{mark} {res.name} ({src}): {counted}, extras {he}/{len(extra)}; runs {runs or '-'}"
        if res.robot:
            head += f"; on {res.robot}"
        if res.error:
            head += f"; FAILED this time ({res.error}), earlier results shown"
        lines.append(_clip(head, width))
        if verbose:
            for c in claims:
                lines.extend(_claim_line(c, width, "     ", compare, res.name, res.verdict(c)))
            continue
        failing = [c for c in book if not res.verdict(c).held]
        if failing:
            more = f" (+{len(failing) - 1} more)" if len(failing) > 1 else ""
            first = failing[0]
            v = res.verdict(first)
            how = f"{v.label} across twins" if v.across else "fails"
            text = f"     {how}: {first.get('text', '')}{_run_value(v, label=False)}"
            lines.append(_clip(text, width - len(more)) + more)
            lines.extend(_why(first, width, "            "))
    n = counts(results)
    tail = f"extras of ours (not the book's claims): {n['extra_held']} of {n['extra']} hold"
    if n["unlabelled"]:
        tail += f" ({n['unlabelled']} claims carry no 'book' field and are counted here)"
    count = f"{len(results)} stud{'y' if len(results) == 1 else 'ies'}"
    lines.append(_clip(f"{tail}; {count}", width))
    return lines
