"""Reading a results folder: each study's ``metrics.json`` (SPEC.md section 6), its figures,
and the run record ``run.json`` written by ``mwip reproduce``.

Everything the summary and the report say comes from these files, never from the text of a
study's module: a verdict is the ``holds`` of a claim in ``metrics.json``, or for a Chapter 6
claim judged across the posterior's twins its across-twins verdict from ``run.json``
(:func:`mwip.report.verdict.claim_verdict`, the one source of a claim's verdict).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mwip.report.verdict import Verdict, across_twins, claim_verdict
from mwip.schema.texts import study_texts

__all__ = [
    "StudyResult",
    "load_results",
    "load_run_record",
    "relative_diff",
]

RUN_RECORD = "run.json"


@dataclass(frozen=True)
class StudyResult:
    """One study's outcome in a results folder.

    ``doc`` is the metrics document (``None`` when the study failed or has not run);
    ``error`` the failure message from the run record, if any.
    """

    name: str
    folder: Path
    doc: dict[str, Any] | None
    figures: tuple[Path, ...] = ()
    error: str | None = None
    wall_s: float | None = None
    info: dict[str, str] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    #: what the study ran on besides the book's robot (run.json ``robot``), e.g.
    #: ``"robot examples/my_robot.toml"``; ``None``: the book's robot and the default twin
    robot: str | None = None
    #: claim id -> its across-twins verdict (:func:`mwip.report.verdict.across_twins`); empty
    #: where the study is not judged across the identified twins
    across: dict[str, str] = field(default_factory=dict)

    @property
    def claims(self) -> list[dict[str, Any]]:
        return list(self.doc.get("claims", [])) if self.doc else []

    def verdict(self, claim: dict[str, Any]) -> Verdict:
        """The claim's one verdict (:func:`mwip.report.verdict.claim_verdict`)."""
        return claim_verdict(claim, self.across)

    @property
    def held(self) -> tuple[int, int]:
        """(claims that hold, claims)."""
        c = self.claims
        return sum(self.verdict(x).held for x in c), len(c)

    def comparison(self) -> list[tuple[str, float | None, float, float | None]]:
        """``(key, ours, published, relative difference)`` for every published number."""
        if not self.doc:
            return []
        ours = self.doc.get("metrics", {})
        rows = []
        for key, pub in self.doc.get("published", {}).items():
            val = ours.get(key)
            rows.append((key, val, pub, relative_diff(val, pub)))
        return rows


def relative_diff(ours: Any, published: Any) -> float | None:
    """``(ours - published) / |published|``; ``None`` where undefined (missing, zero)."""
    try:
        o, p = float(ours), float(published)
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(o) and math.isfinite(p)) or p == 0.0:
        return None
    return (o - p) / abs(p)


def load_run_record(out: Path) -> dict[str, Any]:
    """``OUT/run.json`` as written by ``mwip reproduce`` ({} if absent or unreadable)."""
    path = Path(out) / RUN_RECORD
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return {}
    if not isinstance(doc, dict):
        return {}
    if not isinstance(doc.get("studies", {}), dict):
        doc["studies"] = {}
    return {**doc, "studies": {k: v for k, v in doc.get("studies", {}).items()
                               if isinstance(v, dict)}}  # fmt: skip


def _shape_problem(doc: Any) -> str | None:
    """What makes ``doc`` unusable as a metrics document (SPEC.md section 6), if anything."""
    if not isinstance(doc, dict):
        return f"a JSON {type(doc).__name__}, not an object"
    if "claims" not in doc and "metrics" not in doc:
        return "no 'claims' and no 'metrics' (an empty metrics document)"
    for key in ("metrics", "published", "runs", "settings"):
        if key in doc and not isinstance(doc[key], dict):
            return f"'{key}' must be an object, got a {type(doc[key]).__name__}"
    claims = doc.get("claims", [])
    if not isinstance(claims, list) or not all(isinstance(c, dict) for c in claims):
        return "'claims' must be a list of objects"
    return None


def load_results(out: Path, names: list[str] | None = None) -> list[StudyResult]:
    """The studies in ``out``, in ``names`` order (default: the studies of the run record
    ``run.json`` in its order, then any other folder with a ``metrics.json``, by name).

    A study with no readable ``metrics.json`` is returned with ``doc=None`` and the error
    recorded in ``run.json`` (or "not run").
    """
    out = Path(out)
    record = load_run_record(out)
    per_study = record.get("studies", {})
    across = across_twins(record)
    if names is None:
        found = sorted(p.parent.name for p in out.glob("*/metrics.json"))
        names = [*per_study, *(n for n in found if n not in per_study)]
    results = []
    for name in names:
        folder = out / name
        rec = per_study.get(name, {})
        doc: dict[str, Any] | None
        path = folder / "metrics.json"
        bad = None
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            doc = None
        except (OSError, ValueError, RecursionError) as exc:
            doc, bad = None, " ".join(str(exc).split()) or type(exc).__name__
        if doc is not None:
            problem = _shape_problem(doc)
            if problem is not None:
                doc, bad = None, problem
        if bad is not None:
            error: str | None = f"{path} is unreadable: {bad}"
        else:
            error = rec.get("error") or (None if doc is not None else "not run")
        figures = tuple(sorted(folder.glob("*.png"))) if folder.is_dir() else ()
        results.append(
            StudyResult(name=name, folder=folder, doc=doc, figures=figures, error=error,
                        wall_s=rec.get("wall_s"), info=study_texts(name),
                        settings=dict(rec.get("settings") or {}) if isinstance(
                            rec.get("settings"), dict) else {},
                        robot=str(rec["robot"]) if rec.get("robot") else None,
                        across={} if rec.get("robot") else
                        {cid: v for (s, cid), v in across.items() if s == name})
        )  # fmt: skip
    return results
