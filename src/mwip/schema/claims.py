"""Claims as data (SPEC.md section 6; issue 12): what a study says, whether it holds, and why a
book claim does not.

A claim in ``metrics.json`` is ``{"id", "text", "holds", "book"}``, plus ``"cause"`` (a key of
:data:`CAUSES`) and ``"evidence"`` for a book claim that does not hold; it may name the metric
keys it is decided on (``"keys"``), whose values :func:`mwip.schema.metrics.metrics_document`
copies into it (``"values"``). :class:`Claim` is one claim, typed and checked on creation;
:func:`validate_claim` checks the dict a study writes, :func:`finish_claims` is the one
post-processing every study applies before writing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["CAUSES", "Claim", "validate_claim", "finish_claims"]

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

_FIELDS = ("id", "text", "holds", "book", "cause", "evidence", "keys", "values")


@dataclass(frozen=True)
class Claim:
    """One claim of a study, checked on creation (``ValueError`` naming the field).

    ``id`` is stable within the study (e.g. ``"order.d1"``: how runs under other settings or
    readings are matched); ``book`` is ``True`` for a claim the book makes, ``False`` for an
    extra reading of ours. A book claim that does not hold needs ``cause`` (a key of
    :data:`CAUSES`) and ``evidence`` (non-empty text with the deciding numbers). ``keys`` name
    the deciding metrics, ``values`` their values; ``extra`` keeps any other field as written.
    """

    id: str
    text: str
    holds: bool
    book: bool
    cause: str | None = None
    evidence: str | None = None
    keys: tuple[str, ...] = ()
    values: Mapping[str, Any] = field(default_factory=dict)
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.text, str) or not self.text:
            raise ValueError(f"claim {self.id!r}: 'text' must be a non-empty string")
        if not isinstance(self.id, str) or not self.id:
            raise ValueError(f"claim {self.text!r}: 'id' must be a non-empty string")
        if not isinstance(self.holds, bool):
            raise ValueError(f"claim {self.id!r}: 'holds' must be true or false")
        if not isinstance(self.book, bool):
            raise ValueError(f"claim {self.id!r}: 'book' must be true or false")
        if self.book and not self.holds:
            if self.cause not in CAUSES:
                raise ValueError(
                    f"claim {self.id!r}: a failing book claim needs 'cause', one of "
                    f"{', '.join(CAUSES)}; got {self.cause!r}"
                )
            if not isinstance(self.evidence, str) or not self.evidence.strip():
                raise ValueError(f"claim {self.id!r}: a failing book claim needs non-empty "
                                 "'evidence'")  # fmt: skip

    @classmethod
    def from_dict(cls, claim: Mapping[str, Any]) -> Claim:
        """The claim of a metrics document's entry (``holds`` read as a truth value)."""
        text = claim.get("text")
        if not isinstance(text, str) or not text:
            raise ValueError(f"claim {dict(claim)!r}: 'text' must be a non-empty string")
        cid = claim.get("id")
        if not isinstance(cid, str) or not cid:
            raise ValueError(f"claim {text!r}: 'id' must be a non-empty string")
        if "holds" not in claim:
            raise ValueError(f"claim {cid!r}: 'holds' is missing")
        return cls(
            id=cid, text=text, holds=bool(claim["holds"]), book=claim.get("book"),  # type: ignore[arg-type]
            cause=claim.get("cause"), evidence=claim.get("evidence"),
            keys=tuple(claim.get("keys") or ()), values=dict(claim.get("values") or {}),
            extra={k: v for k, v in claim.items() if k not in _FIELDS},
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        """The metrics document's entry (fields that are unset left out)."""
        out: dict[str, Any] = {"id": self.id, "text": self.text, "holds": self.holds,
                               "book": self.book}  # fmt: skip
        for name in ("cause", "evidence"):
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        if self.keys:
            out["keys"] = list(self.keys)
        if self.values:
            out["values"] = dict(self.values)
        return {**out, **self.extra}


def validate_claim(claim: Mapping[str, Any]) -> dict[str, Any]:
    """Check one claim's fields (:class:`Claim`) and return a copy with ``holds`` a bool, its
    fields in the order written. Raises ``ValueError`` naming the field."""
    Claim.from_dict(claim)
    c = dict(claim)
    c["holds"] = bool(c["holds"])
    return c


def finish_claims(
    claims: list[dict[str, Any]], metrics: Mapping[str, Any], robot: str = ""
) -> list[dict[str, Any]]:
    """Claims ready for :func:`~mwip.schema.metrics.metrics_document`, the same for every
    study: ``cause`` and ``evidence`` removed where a claim holds (they explain only a
    failure; a failing claim keeps what the study gave), and a failing book claim that the
    study has no explanation for (e.g. under a user's settings) marked
    ``cause = "implementation"`` with its deciding numbers as evidence: an unexplained gap is
    ours until explained. ``robot`` names the robot that ran, for that evidence."""
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
