"""Comparing declared twin structures by their evidence (issue 38, items 3-4): what each
structure can meet, how probable the calibration facts are under it, and verdicts that say
what they rest on.

Each structure ``S`` (a twin with its declared prior) is drawn and run; its fact table says
which calibration facts each draw meets (:class:`mwip.calibration.posterior.Facts`). The
draws may come from a proposal instead of the prior: ``weights`` are then the importance
weights ``p(x) / q(x)``, so that ``mean(w f)`` estimates the prior expectation of ``f``
(prior draws: ``w = 1``).

- **Evidence** (the marginal likelihood of "every fact met", an ABC evidence with the facts'
  0/1 kernel): ``Z_S = P_prior(all facts met) ~ mean_i w_i 1[draw i meets all]``. Its 95 %
  interval: for prior draws, Clopper-Pearson's exact binomial interval; for weighted draws,
  the normal interval of the mean on the log scale (delta method), and where no draw meets
  all facts the rule-of-three-type bound ``-ln(0.025) max(w) / N`` (a conservative bound:
  every weight at its largest).
- **What a structure can meet**: the facts no draw meets even alone (*unmet*); the most facts
  one draw meets together; the largest consistent subset and the smallest conflicting sets
  (:func:`mwip.calibration.posterior.consistent_subset`). A structure none of whose draws
  meets every fact is **rejected**, and the facts outside its largest consistent subset are
  the facts that reject it: "structure rejected by this fact", never a held-out failure.
- **Bayes factors** ``B_AB = Z_A / Z_B`` with their intervals (the log intervals combined);
  where ``Z_B = 0`` only a lower bound ``Z_A,lo / Z_B,hi``. **Posterior probabilities** of
  the structures: ``p(S | facts) = pi_S Z_S / sum_T pi_T Z_T`` (equal prior ``pi`` unless
  given).
- **Held-out verdicts** per structure: a claim that needs a fact the structure is rejected by
  (a run that must stand) is *not judgeable on S*; otherwise the weighted share of the
  structure's consistent twins where it holds decides: *holds* at least ``decided``, *fails*
  at most ``1 - decided``, else *undecided* (the declaration's rule). Averaged over the
  structures where it is judgeable, by their posterior probabilities renormalised over them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.calibration.posterior import Facts, consistent_subset

__all__ = ["Evidence", "StructureEvidence", "evidence_of", "bayes_factor", "posterior_probs",
           "claim_verdict", "Verdict"]  # fmt: skip

_ALPHA = 0.05


@dataclass(frozen=True)
class Evidence:
    """``Z`` and its 95 % interval."""

    z: float
    lo: float
    hi: float
    hits: int  # draws meeting every fact
    n: int


@dataclass(frozen=True)
class StructureEvidence:
    """One structure's evidence and what it can meet (module docstring)."""

    name: str
    evidence: Evidence
    unmet: tuple[str, ...]  # facts no draw meets alone
    most_together: int  # the most facts one draw meets
    rejected_by: tuple[str, ...]  # outside the largest consistent subset (empty: consistent)
    conflicts: tuple[tuple[str, ...], ...]  # smallest conflicting sets
    accepted: NDArray[np.bool_]  # (N,) draws meeting every fact
    weights: NDArray[np.float64]  # (N,)
    conditioned: NDArray[np.bool_]  # (N,) draws meeting the largest consistent subset

    @property
    def rejected(self) -> bool:
        """No draw meets every fact (existence: whatever estimates ``Z``)."""
        return not bool(self.accepted.any())

    def to_json(self) -> dict[str, Any]:
        e = self.evidence
        return {"name": self.name, "evidence": e.z, "evidence_95": [e.lo, e.hi],
                "hits": e.hits, "draws": e.n, "found": int(self.accepted.sum()),
                "searched": int(self.accepted.size), "rejected": self.rejected,
                "rejected_by": list(self.rejected_by), "unmet": list(self.unmet),
                "most_facts_together": self.most_together,
                "conflicts": [list(c) for c in self.conflicts]}  # fmt: skip


def _evidence(hit: NDArray[np.bool_], w: NDArray[np.float64]) -> Evidence:
    from scipy import stats

    n = int(hit.size)
    k = int(hit.sum())
    if n == 0:
        return Evidence(float("nan"), 0.0, 1.0, 0, 0)
    if np.all(w == 1.0):
        z = k / n
        lo = float(stats.beta.ppf(_ALPHA / 2, k, n - k + 1)) if k > 0 else 0.0
        hi = float(stats.beta.ppf(1 - _ALPHA / 2, k + 1, n - k)) if k < n else 1.0
        return Evidence(z, lo, hi, k, n)
    x = w * hit
    z = float(x.mean())
    if k == 0:
        return Evidence(0.0, 0.0, float(-np.log(_ALPHA / 2) * w.max() / n), 0, n)
    se = float(x.std(ddof=1) / np.sqrt(n)) if n > 1 else z
    s = se / z
    q = float(stats.norm.ppf(1 - _ALPHA / 2))
    return Evidence(z, z * float(np.exp(-q * s)), z * float(np.exp(q * s)), k, n)


def evidence_of(name: str, f: Facts, weights: NDArray[np.float64] | None = None,
                ) -> StructureEvidence:  # fmt: skip
    """The evidence and what the structure ``name`` can meet, from its fact table ``f``."""
    S = f.S
    w = np.ones(S.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (S.shape[0],) or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights: {S.shape[0]} finite non-negative numbers needed")
    hit = np.all(S, axis=1)
    mask, conflicts = consistent_subset(f)
    return StructureEvidence(
        name=name, evidence=_evidence(hit, w),
        unmet=tuple(n for j, n in enumerate(f.names) if not S[:, j].any()),
        most_together=int(S.sum(axis=1).max()) if S.shape[0] else 0,
        rejected_by=tuple(n for n, m in zip(f.names, mask, strict=True) if not m),
        conflicts=tuple(tuple(c) for c in conflicts), accepted=hit, weights=w,
        conditioned=np.all(S[:, mask], axis=1) if S.shape[0] else hit,
    )  # fmt: skip


def bayes_factor(a: StructureEvidence, b: StructureEvidence) -> tuple[float, float, float]:
    """``(B, lo, hi)`` of ``B_ab = Z_a / Z_b`` (module docstring); ``B = inf`` with ``lo``
    the lower bound where ``Z_b = 0``, ``nan`` where both are 0."""
    za, zb = a.evidence, b.evidence
    if za.z == 0 and zb.z == 0:
        return float("nan"), 0.0, float("inf")
    if zb.z == 0:
        return float("inf"), za.lo / zb.hi if zb.hi > 0 else float("inf"), float("inf")
    if za.z == 0:
        return 0.0, 0.0, za.hi / zb.lo if zb.lo > 0 else float("inf")
    q = 1.959963984540054
    sa = np.log(za.hi / za.lo) / (2 * q)
    sb = np.log(zb.hi / zb.lo) / (2 * q)
    s = float(np.hypot(sa, sb))
    B = za.z / zb.z
    return B, B * float(np.exp(-q * s)), B * float(np.exp(q * s))


def posterior_probs(structs: Sequence[StructureEvidence],
                    prior: Mapping[str, float] | None = None) -> dict[str, float]:  # fmt: skip
    """``p(S | facts)`` of each structure (equal prior unless ``prior``); all 0 where no
    structure meets the facts."""
    pi = {s.name: (1.0 if prior is None else float(prior[s.name])) for s in structs}
    tot = sum(pi[s.name] * s.evidence.z for s in structs)
    return {s.name: (pi[s.name] * s.evidence.z / tot if tot > 0 else 0.0) for s in structs}


@dataclass(frozen=True)
class Verdict:
    """A held-out claim's verdict per structure and over them."""

    per_structure: dict[str, tuple[str, float | None]]  # name -> (verdict, share holding)
    overall: str
    p_holds: float | None  # over the judgeable structures, by their posterior probability


def _word(share: float, decided: float) -> str:
    return "holds" if share >= decided else "fails" if share <= 1 - decided else "undecided"


def claim_verdict(holds: Mapping[str, NDArray[np.bool_]], needs: Sequence[str],
                  structs: Sequence[StructureEvidence], decided: float = 0.95,
                  prior: Mapping[str, float] | None = None) -> Verdict:  # fmt: skip
    """The verdict of one held-out claim (module docstring): ``holds[S]`` (N_S,) whether it
    holds on each draw of ``S`` (read on the draws meeting the structure's largest consistent
    subset: all facts where it is not rejected), ``needs`` the facts it rests on (e.g.
    ``up:<run>`` of the runs it compares). A rejected structure has posterior probability 0,
    so its own verdict is shown but does not enter the average."""
    post = posterior_probs(structs, prior)
    per: dict[str, tuple[str, float | None]] = {}
    num = den = 0.0
    for s in structs:
        if set(needs) & set(s.rejected_by) or not s.conditioned.any():
            per[s.name] = ("not judgeable", None)
            continue
        w = s.weights[s.conditioned]
        h = np.asarray(holds[s.name], dtype=bool)[s.conditioned]
        share = float(np.sum(w * h) / np.sum(w))
        per[s.name] = (_word(share, decided), share)
        num += post[s.name] * share
        den += post[s.name]
    if den <= 0:
        return Verdict(per, "not judgeable", None)
    p = num / den
    return Verdict(per, _word(p, decided), p)
