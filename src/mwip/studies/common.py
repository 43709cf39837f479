"""Helpers shared by the studies: the metrics document and figure saving."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.io import write_atomic, write_json_atomic

__all__ = [
    "CAUSES",
    "finish_claims",
    "metrics_document",
    "save_figure",
    "to_jsonable",
    "validate_claim",
]

#: Why a book claim does not hold (issue 12; SPEC.md section 3). Every book claim that fails
#: names one of these as ``"cause"``, with ``"evidence"``: one or two sentences whose numbers
#: are computed by the study's own runs.
CAUSES: dict[str, str] = {
    "implementation": "a limitation or defect of this implementation",
    "damping-reading": "decided by how the tables' Db, Dw are read (SPEC.md section 2)",
    "book-inconsistency": "the book's printed numbers contradict the claim (SPEC.md section 3)",
    "unprinted-setting": "depends on a setting the book does not print",
    "twin-model": "the digital twin differs from the real robot in what decides it",
    "claim-definition": "the claim as worded cannot hold for this plant; its reachable form is "
    "judged beside it",
}


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

    A claim is data (:func:`validate_claim`): ``{"id": str, "text": str, "holds": bool,
    "book": bool}``, plus ``"cause"`` and ``"evidence"`` for a book claim that does not hold,
    and it may name the metric keys it is decided on, ``"keys": [...]``; their values are
    copied into the claim as ``"values"`` so the summary and the report show the deciding
    numbers. A key that is not in ``metrics`` is a programming error (``KeyError``).
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


def validate_claim(claim: dict[str, Any]) -> dict[str, Any]:
    """Check one claim's fields and return a normalised copy.

    Required: ``id`` (stable within the study, e.g. ``"order.d1"``: how runs under other
    settings or readings are matched), ``text``, ``holds``, ``book`` (``True``: the book makes
    this claim; ``False``: an extra reading of ours). A book claim that does not hold also
    needs ``cause`` (a key of :data:`CAUSES`) and ``evidence`` (non-empty text with the deciding
    numbers, computed in the study). Raises ``ValueError`` naming the field.
    """
    c = dict(claim)
    text = c.get("text")
    if not isinstance(text, str) or not text:
        raise ValueError(f"claim {claim!r}: 'text' must be a non-empty string")
    cid = c.get("id")
    if not isinstance(cid, str) or not cid:
        raise ValueError(f"claim {text!r}: 'id' must be a non-empty string")
    if "holds" not in c:
        raise ValueError(f"claim {cid!r}: 'holds' is missing")
    c["holds"] = bool(c["holds"])
    if not isinstance(c.get("book"), bool):
        raise ValueError(f"claim {cid!r}: 'book' must be true or false")
    if c["book"] and not c["holds"]:
        if c.get("cause") not in CAUSES:
            raise ValueError(
                f"claim {cid!r}: a failing book claim needs 'cause', one of {', '.join(CAUSES)}"
                f"; got {c.get('cause')!r}"
            )
        if not isinstance(c.get("evidence"), str) or not c["evidence"].strip():
            raise ValueError(f"claim {cid!r}: a failing book claim needs non-empty 'evidence'")
    return c


def write_metrics(folder: Path, doc: dict[str, Any]) -> Path:
    """Write ``folder/metrics.json`` atomically."""
    return write_json_atomic(folder / "metrics.json", doc)


#: The widest a study figure is drawn (px): the report shows figures at most about 1200 px
#: wide at a 1280 px window (:data:`SHOWN_PX`), so none is shrunk by more than about 1.2x.
MAX_FIGURE_PX = 1440
SHOWN_PX = 1200
#: The smallest text (px) a figure may show where the report displays it.
MIN_TEXT_PX = 10.0


def _readable_text(fig: Figure, dpi: float) -> None:
    """Raise every text of ``fig`` smaller than :data:`MIN_TEXT_PX` at its displayed size
    (the figure shrunk to :data:`SHOWN_PX` wide if it is wider) to that size."""
    from matplotlib.text import Text

    shrink = max(1.0, fig.get_figwidth() * dpi / SHOWN_PX)
    min_pt = MIN_TEXT_PX * shrink * 72.0 / dpi
    for ax in fig.axes:
        for axis, which in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            labels = axis.get_ticklabels()
            if labels and float(labels[0].get_fontsize()) < min_pt:
                ax.tick_params(axis=which, labelsize=min_pt)  # type: ignore[arg-type]
    for text in fig.findobj(Text):
        if isinstance(text, Text) and text.get_text() and float(text.get_fontsize()) < min_pt:
            text.set_fontsize(min_pt)


def save_figure(fig: Figure, path: Path) -> Path:
    """Save a matplotlib figure as PNG atomically (no pyplot, no global backend), at 120 dpi
    or, for a figure wider than 12 in, at the dpi that makes it :data:`MAX_FIGURE_PX` wide;
    text too small to read where the report shows the figure is enlarged first."""
    dpi = min(120.0, MAX_FIGURE_PX / float(fig.get_figwidth()))
    _readable_text(fig, dpi)
    return write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi))


def finish_claims(
    claims: list[dict[str, Any]], metrics: dict[str, float], robot: str = ""
) -> list[dict[str, Any]]:
    """Claims ready for :func:`metrics_document`: ``cause``/``evidence`` removed where a claim
    holds (they explain only a failure), and a failing book claim that the study has no
    explanation for (e.g. under a user's settings) marked ``cause = "implementation"`` with its
    deciding numbers as evidence: an unexplained gap is ours until explained. ``robot`` names
    the robot that ran, for that evidence."""
    out = []
    for c in claims:
        c = dict(c)
        if c["holds"]:
            c.pop("cause", None)
            c.pop("evidence", None)
        elif c.get("book") and "cause" not in c:
            values = ", ".join(f"{k} = {_num(metrics[k])}" for k in c.get("keys", []))
            c["cause"] = "implementation"
            where = f" on the {robot}" if robot else ""
            c["evidence"] = (
                f"not explained by this study{where} with these settings: "
                f"{values or 'no deciding metric'}."
            )
        out.append(c)
    return out


def _num(x: Any) -> str:
    """A metric for evidence text (``None`` and non-numbers as written)."""
    return f"{x:.4g}" if isinstance(x, int | float) else str(x)
