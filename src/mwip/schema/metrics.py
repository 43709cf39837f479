"""The metrics document, ``OUT/<study>/metrics.json`` (SPEC.md section 6): what every study
writes and every reader (summary, report, figures, campaigns) reads."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mwip.io import write_json_atomic
from mwip.schema.claims import validate_claim

__all__ = ["metrics_document", "to_jsonable", "write_metrics"]


def to_jsonable(x: Any) -> Any:
    """Convert NumPy scalars/arrays (and containers of them) to JSON-friendly values."""
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def metrics_document(
    study: str,
    source: str,
    metrics: dict[str, float],
    published: dict[str, float],
    claims: list[dict[str, Any]],
    runs: dict[str, dict[str, Any]],
    settings: dict[str, Any],
) -> dict[str, Any]:
    """The metrics.json document of SPEC.md section 6.

    A claim is data (:func:`~mwip.schema.claims.validate_claim`): ``{"id": str, "text": str,
    "holds": bool, "book": bool}``, plus ``"cause"`` and ``"evidence"`` for a book claim that
    does not hold, and it may name the metric keys it is decided on, ``"keys": [...]``; their
    values are copied into the claim as ``"values"`` so the summary and the report show the
    deciding numbers. A key that is not in ``metrics`` is a programming error (``KeyError``).
    """
    resolved = []
    seen: set[str] = set()
    for c in claims:
        c = validate_claim(c)
        if c["id"] in seen:
            raise ValueError(f"{study}: claim id {c['id']!r} is used twice")
        seen.add(c["id"])
        keys = c.get("keys")
        if keys:
            missing = [k for k in keys if k not in metrics]
            if missing:
                raise KeyError(f"claim {c['text']!r} names unknown metrics {missing}")
            c["values"] = {k: metrics[k] for k in keys}
        resolved.append(c)
    claims = resolved
    return to_jsonable(
        {
            "study": study,
            "source": source,
            "metrics": metrics,
            "published": published,
            "claims": claims,
            "runs": runs,
            "settings": settings,
        }
    )


def write_metrics(folder: Path, doc: dict[str, Any]) -> Path:
    """Write ``folder/metrics.json`` atomically."""
    return write_json_atomic(folder / "metrics.json", doc)
