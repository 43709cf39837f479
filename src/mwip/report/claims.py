"""Claims as data, for the summary and the report: which are the book's, which hold, why a
book claim does not (its ``cause`` and ``evidence``), and how it fares under the other reading
of the damping (SPEC.md section 2) in a second results folder.

A claim in ``metrics.json`` is ``{"id", "text", "holds", "book"}`` plus, for a failing book
claim, ``"cause"`` (a key of :data:`mwip.schema.claims.CAUSES`) and ``"evidence"``
(:func:`mwip.schema.claims.validate_claim`). A claim without ``"book": true`` is counted
with the extras (no guessing from its wording); a claim without an ``id`` is matched across
folders by its text.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mwip.report.results import StudyResult, load_results, load_run_record
from mwip.schema.claims import CAUSES

__all__ = [
    "CAUSES",
    "Comparison",
    "NO_CAUSE",
    "book_claims",
    "cause_label",
    "claim_key",
    "counts",
    "find_compare",
    "is_book",
    "load_comparison",
]

#: The group of failing book claims that name no cause (a study not converted yet).
NO_CAUSE = "not given"


def is_book(claim: dict[str, Any]) -> bool:
    """A claim the book makes: ``"book": true`` in metrics.json (nothing else counts)."""
    return claim.get("book") is True


def claim_key(study: str, claim: dict[str, Any]) -> tuple[str, str]:
    """How a claim is matched across results folders: study and ``id`` (else its text)."""
    cid = claim.get("id")
    return (study, str(cid) if cid else "text:" + str(claim.get("text", "")))


def cause_label(cause: Any) -> str:
    """``"cause: description"`` for a cause of :data:`CAUSES`; the raw value otherwise."""
    if cause in CAUSES:
        return f"{cause}: {CAUSES[cause]}"
    return NO_CAUSE if not cause else str(cause)


def book_claims(results: list[StudyResult]) -> list[tuple[StudyResult, dict[str, Any]]]:
    """Every book claim of ``results``, in study order."""
    return [(r, c) for r in results for c in r.claims if is_book(c)]


def counts(results: list[StudyResult]) -> dict[str, int]:
    """``book_held``, ``book``, ``extra_held``, ``extra`` and ``unlabelled`` (claims with no
    ``book`` field, counted among the extras), each claim by its one verdict
    (:meth:`StudyResult.verdict`); ``across`` the claims judged across the twins and
    ``across:<verdict>`` how many have each across-twins verdict."""
    out = dict.fromkeys(("book_held", "book", "extra_held", "extra", "unlabelled", "across"), 0)
    for r in results:
        for c in r.claims:
            v = r.verdict(c)
            kind = "book" if is_book(c) else "extra"
            out[kind] += 1
            out[f"{kind}_held"] += v.held
            out["unlabelled"] += "book" not in c
            if v.across:
                out["across"] += 1
                out[f"across:{v.label}"] = out.get(f"across:{v.label}", 0) + 1
    return out


@dataclass(frozen=True)
class Comparison:
    """The verdicts of a second results folder (another damping reading): ``folder``, its
    ``damping`` reading (from its run.json; ``None`` if unrecorded), and ``verdicts``
    (:func:`claim_key` -> holds)."""

    folder: Path
    damping: str | None
    verdicts: dict[tuple[str, str], bool]  # each claim's one verdict there: held or not
    results: tuple[StudyResult, ...] = ()
    #: why a study there was left out (its metrics.json unreadable): said, never dropped silently
    unreadable: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        return f"{self.damping} reading" if self.damping else f"run in {self.folder.name}"

    def verdict(self, study: str, claim: dict[str, Any]) -> bool | None:
        """The claim's verdict there (``None``: not in that run)."""
        return self.verdicts.get(claim_key(study, claim))


def load_comparison(folder: Path) -> Comparison:
    """The verdicts in ``folder`` (a results folder of ``mwip reproduce``/``run``)."""
    folder = Path(folder)
    loaded = load_results(folder)
    results = [r for r in loaded if r.doc is not None]
    unreadable = tuple(str(r.error) for r in loaded
                       if r.doc is None and r.error and "unreadable" in r.error)  # fmt: skip
    verdicts = {claim_key(r.name, c): r.verdict(c).held for r in results for c in r.claims}
    damping = load_run_record(folder).get("damping")
    return Comparison(folder=folder, damping=damping, verdicts=verdicts, results=tuple(results),
                      unreadable=unreadable)  # fmt: skip


def find_compare(out: Path) -> Path | None:
    """The comparison folder ``OUT/compare-<reading>`` that ``mwip reproduce`` writes under
    the other damping reading (``None`` if there is none)."""
    own = load_run_record(out).get("damping")
    for path in sorted(Path(out).glob("compare-*")):
        if (path / "run.json").is_file() and load_run_record(path).get("damping") != own:
            return path
    return None
