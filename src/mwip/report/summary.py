"""The one-screen summary ``mwip reproduce`` ends with: every claim, holds or not, with the
numbers that decide it, read from each study's ``metrics.json``."""

from __future__ import annotations

import math
from typing import Any

from mwip.report.results import StudyResult

__all__ = ["format_number", "summary_lines"]


def format_number(x: Any) -> str:
    """Compact number for tables: 4 significant digits, ``-`` for missing."""
    if x is None:
        return "-"
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


def summary_lines(results: list[StudyResult], width: int = 100) -> list[str]:
    """Lines of the summary: per study a header, then ``[ok]``/``[no]`` per claim with the
    deciding values (``values`` of the claim, from ``metrics.json``)."""
    lines: list[str] = []
    total_held = total = 0
    for res in results:
        held, n = res.held
        total_held += held
        total += n
        src = res.doc.get("source", "") if res.doc else res.info.get("source", "")
        if res.doc is None:
            lines.append(_clip(f"{res.name} ({src}): FAILED - {res.error}", width))
            continue
        status = ", ".join(sorted({str(r.get("status")) for r in res.doc.get("runs", {}).values()}))
        head = f"{res.name} ({src}): {held}/{n} claims hold; runs {status or '-'}"
        if res.error:
            head += f"; FAILED this time ({res.error}), earlier results shown"
        lines.append(_clip(head, width))
        for c in res.claims:
            mark = "[ok]" if c.get("holds") else "[no]"
            vals = f"  <{_values(c)}>" if c.get("values") else ""
            vals = _clip(vals, width // 2)
            lines.append(_clip(f"  {mark} {c.get('text', '')}", width - len(vals)) + vals)
    lines.append(f"claims holding: {total_held}/{total} over {len(results)} studies")
    return lines
