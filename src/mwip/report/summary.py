"""The one-screen summary ``mwip reproduce`` ends with: every claim, holds or not, with the
numbers that decide it, read from each study's ``metrics.json``."""

from __future__ import annotations

import math
from typing import Any

from mwip.report.results import StudyResult

__all__ = ["format_number", "summary_lines"]


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


def is_book_claim(claim: dict[str, Any]) -> bool:
    """A claim the book makes (``"book": true``, or its text cites the book and it is not one
    of our extra readings, e.g. "[extra: ideal sensors and actuator]")."""
    if "book" in claim:
        return bool(claim["book"])
    text = str(claim.get("text", "")).lower()
    return "book" in text and "extra" not in text


def _claim_line(c: dict[str, Any], width: int, indent: str = "  ") -> str:
    mark = "[ok]" if c.get("holds") else "[no]"
    vals = _clip(f"  <{_values(c)}>", width // 2) if c.get("values") else ""
    return _clip(f"{indent}{mark} {c.get('text', '')}", width - len(vals)) + vals


def summary_lines(results: list[StudyResult], width: int = 100, verbose: bool = False) -> list[str]:
    """The summary, from each study's ``metrics.json``.

    Default (one screen): per study one line - ``[ok]`` when every book claim holds - with
    the counts of book claims and of all claims that hold, and the first failing book claim
    with its deciding numbers (``values`` of the claim). ``verbose``: every claim.
    """
    lines: list[str] = []
    held_all = total_all = held_book = total_book = 0
    for res in results:
        src = res.doc.get("source", "") if res.doc else res.info.get("source", "")
        if res.doc is None:
            lines.append(_clip(f"[!!] {res.name} ({src}): FAILED - {res.error}", width))
            continue
        claims = res.claims
        book = [c for c in claims if is_book_claim(c)]
        hb = sum(bool(c.get("holds")) for c in book)
        ha = sum(bool(c.get("holds")) for c in claims)
        held_all, total_all = held_all + ha, total_all + len(claims)
        held_book, total_book = held_book + hb, total_book + len(book)
        runs = ", ".join(sorted({str(r.get("status")) for r in res.doc.get("runs", {}).values()}))
        mark = "[ok]" if hb == len(book) else "[no]"
        counted = f"book claims {hb}/{len(book)}" if book else "no book claim"
        head = f"{mark} {res.name} ({src}): {counted}, all {ha}/{len(claims)}; runs {runs or '-'}"
        if res.error:
            head += f"; FAILED this time ({res.error}), earlier results shown"
        lines.append(_clip(head, width))
        if verbose:
            lines.extend(_claim_line(c, width, "     ") for c in claims)
            continue
        failing = [c for c in book if not c.get("holds")]
        if failing:
            more = f" (+{len(failing) - 1} more)" if len(failing) > 1 else ""
            first = failing[0]
            lines.append(_clip(f"     fails: {first.get('text', '')}", width - len(more)) + more)
            if first.get("values"):
                lines.append(_clip(f"            {_values(first)}", width))
    lines.append(
        f"book claims holding: {held_book}/{total_book}; all claims (with our extra readings): "
        f"{held_all}/{total_all}; over {len(results)} studies"
    )
    return lines
