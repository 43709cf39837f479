"""Comparing twin structures by their evidence (issue 38, items 3-4;
mwip.calibration.compare) on synthetic problems with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.calibration.compare import bayes_factor, claim_verdict, evidence_of, posterior_probs
from mwip.calibration.posterior import Facts

N = 4000


def _facts(x1: np.ndarray, x2: np.ndarray, obs: tuple[float, float], tol: float) -> Facts:
    S = np.column_stack([np.abs(x1 - obs[0]) <= tol, np.abs(x2 - obs[1]) <= tol])
    return Facts(("num:e1", "num:e2"), S, np.zeros((x1.size, 0)))


def test_the_structure_that_made_the_facts_wins_and_the_other_is_rejected_by_a_fact() -> None:
    """Two experiments; structure A (x1 = theta, x2 = 2 theta) made the observations at
    theta* = 0.3; structure B (x1 = theta, x2 = theta + 0.5) meets each fact alone, never both.
    A's evidence is P(|theta - 0.3| <= 0.05 and |2 theta - 0.6| <= 0.05) = 0.05 exactly; B is
    rejected, by one fact of the pair, and the Bayes factor's lower bound favours A."""
    rng = np.random.default_rng(1)
    th_a, th_b = rng.uniform(size=N), rng.uniform(size=N)
    a = evidence_of("A", _facts(th_a, 2 * th_a, (0.3, 0.6), 0.05))
    b = evidence_of("B", _facts(th_b, th_b + 0.5, (0.3, 0.6), 0.05))
    assert a.evidence.lo <= 0.05 <= a.evidence.hi and not a.rejected
    assert b.rejected and b.evidence.z == 0.0 and b.unmet == ()
    assert b.most_together == 1 and len(b.rejected_by) == 1
    assert b.conflicts == (("num:e1", "num:e2"),)
    B, lo, hi = bayes_factor(a, b)
    assert B == np.inf and lo > 10.0
    assert posterior_probs([a, b]) == {"A": 1.0, "B": 0.0}


@pytest.mark.parametrize("weighted", [False, True])
def test_the_bayes_factor_has_the_right_sign_and_size(weighted: bool) -> None:
    """Both structures meet both facts: A's evidence is 0.4 (theta in [0.2, 0.6]), B's
    (y = theta^2 in [0.2, 0.6]) sqrt(0.6) - sqrt(0.2) = 0.3274; B_AB = 1.2217. The estimate's
    interval holds it and excludes 1; the same with draws from a proposal (density 2 theta on
    [0, 1], importance weights 1 / (2 theta))."""
    rng = np.random.default_rng(7)
    if weighted:
        th_a, th_b = np.sqrt(rng.uniform(size=N)), np.sqrt(rng.uniform(size=N))
        wa, wb = 1.0 / (2.0 * th_a), 1.0 / (2.0 * th_b)
    else:
        th_a, th_b = rng.uniform(size=N), rng.uniform(size=N)
        wa = wb = None
    fa = Facts(("f1", "f2"), np.column_stack([th_a > 0.2, th_a < 0.6]), np.zeros((N, 0)))
    y = th_b**2
    fb = Facts(("f1", "f2"), np.column_stack([y > 0.2, y < 0.6]), np.zeros((N, 0)))
    a, b = evidence_of("A", fa, wa), evidence_of("B", fb, wb)
    true = 0.4 / (np.sqrt(0.6) - np.sqrt(0.2))
    assert a.evidence.lo <= 0.4 <= a.evidence.hi
    B, lo, hi = bayes_factor(a, b)
    assert lo <= true <= hi and lo > 1.0, (B, lo, hi)
    p = posterior_probs([a, b])
    assert abs(p["A"] - true / (1 + true)) < 0.05


def test_a_claim_that_needs_a_rejecting_fact_is_not_judgeable_there() -> None:
    """On B (rejected by the second run's standing), a claim comparing the two runs is "not
    judgeable", never "fails"; a claim on the first run alone is judged on B's conditioned
    draws but weighs nothing (B's posterior probability is 0); the average is A's."""
    rng = np.random.default_rng(3)
    n = 1000
    th_a, th_b = rng.uniform(size=n), rng.uniform(size=n)
    fa = Facts(("up:r1", "up:r2"), np.column_stack([th_a > 0.1, th_a < 0.9]), np.zeros((n, 0)))
    fb = Facts(("up:r1", "up:r2"), np.column_stack([th_b > 0.1, np.zeros(n, bool)]),
               np.zeros((n, 0)))  # fmt: skip
    a, b = evidence_of("A", fa), evidence_of("B", fb)
    assert b.rejected and b.rejected_by == ("up:r2",) and b.unmet == ("up:r2",)
    holds = {"A": th_a > 0.0, "B": th_b < 0.0}
    v = claim_verdict(holds, ["up:r1", "up:r2"], [a, b])
    assert v.per_structure["B"] == ("not judgeable", None)
    assert v.per_structure["A"][0] == "holds" and v.overall == "holds"
    v1 = claim_verdict(holds, ["up:r1"], [a, b])
    assert v1.per_structure["B"][0] == "fails" and v1.overall == "holds" and v1.p_holds == 1.0
    none = claim_verdict(holds, ["up:r2"], [b])
    assert none.overall == "not judgeable" and none.p_holds is None


def test_weights_are_checked() -> None:
    f = Facts(("f",), np.ones((3, 1), bool), np.zeros((3, 0)))
    with pytest.raises(ValueError, match="weights"):
        evidence_of("A", f, np.array([1.0, -1.0, 1.0]))
