"""One verdict per claim (issue 38, item 5): the single source of a claim's verdict for the
summary, the report's headline and every claims table.

A Chapter 6 claim that the book calibration judges across the posterior's twins
(:data:`mwip.calibration.claims.CLAIMS`; their verdicts in ``posterior.json``'s ``claims``,
copied to the run record's ``twin_status`` by :func:`mwip.hardware.identified.status`) is
counted by that across-twins verdict: *holds*, *fails*, *undecided* or *not judgeable*. The
run's own result on the default twin (the study's ``holds`` in ``metrics.json``) is shown
beside it as a value, never as a second verdict. Every other claim (not judged across twins,
or run on a robot other than the identified one, or under another damping reading than the
calibration's) keeps its verdict of the run: ``holds`` in ``metrics.json``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["ACROSS", "Verdict", "across_twins", "claim_verdict"]

#: The across-twins verdicts as the report words them (``"no posterior"``: not judgeable).
ACROSS = {"holds": "holds", "fails": "fails", "undecided": "undecided",
          "not judgeable": "not judgeable", "no posterior": "not judgeable"}  # fmt: skip

#: The damping reading the book calibration ran on (its robot: mwip/robot/book.toml's notes).
CALIBRATED_READING = "units"


@dataclass(frozen=True)
class Verdict:
    """A claim's one verdict: ``label`` (``holds`` / ``does not hold`` for a verdict of the
    run; ``holds`` / ``fails`` / ``undecided`` / ``not judgeable`` across twins), ``held``
    (counted as reproducing), ``across`` (judged across the posterior's twins) and
    ``this_run`` (the run's own result on its twin: a value beside an across-twins verdict)."""

    label: str
    held: bool
    across: bool
    this_run: bool | None


def across_twins(record: dict[str, Any]) -> dict[tuple[str, str], str]:
    """``(study, claim id) -> across-twins verdict`` from a run record (``run.json``), or
    ``{}`` where the run is not on the identified twin or not under the calibration's damping
    reading (the calibration's verdicts are then not about this run's robot)."""
    st = record.get("twin_status")
    if not isinstance(st, dict) or not st.get("identified"):
        return {}
    if record.get("damping") not in (None, CALIBRATED_READING):
        return {}
    out = {}
    for c in st.get("claims") or []:
        if isinstance(c, dict) and c.get("study") and c.get("id") and c.get("verdict"):
            v = str(c["verdict"])
            out[(str(c["study"]), str(c["id"]))] = ACROSS.get(v, v)
    return out


def claim_verdict(claim: dict[str, Any], across: dict[str, str] | None = None) -> Verdict:
    """The claim's one verdict; ``across`` is its study's ``claim id -> across-twins verdict``
    (:attr:`mwip.report.results.StudyResult.across`)."""
    run = bool(claim.get("holds"))
    label = (across or {}).get(str(claim.get("id"))) if claim.get("id") else None
    if label is None:
        return Verdict("holds" if run else "does not hold", run, False, run)
    return Verdict(label, label == "holds", True, run)
