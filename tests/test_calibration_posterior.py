"""The conditioning logic of the book calibration on synthetic fact tables (known answers)."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.calibration.claims import auc, judge
from mwip.calibration.evidence import load_evidence
from mwip.calibration.posterior import Facts, _largest_consistent, condition, smallest_conflicts


def test_declaration_reads_and_is_what_was_declared():
    ev = load_evidence()
    assert ev.tolerance == 1.5 and ev.decided == 0.95 and ev.samples >= 2000
    keys = [n.key for n in ev.numbers]
    assert keys == ["exp-hodosmc-balance/smc.case1.rms_theta",
                    "exp-hodosmc-balance/smc.case1.rms_speed_err"]
    assert [n.book for n in ev.numbers] == [0.0216, 1.3240]


def test_smallest_conflicts_finds_exactly_the_minimal_sets():
    # facts a, b, c, d; no draw has (a and b); no draw has d; c is always true
    S = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [0, 0, 1, 0], [1, 0, 1, 0]], dtype=bool)
    got = smallest_conflicts(S, ["a", "b", "c", "d"])
    assert got == [["d"], ["a", "b"]]


def test_smallest_conflicts_triple_only():
    # every pair is satisfied by some draw but never all three
    S = np.array([[1, 1, 0], [1, 0, 1], [0, 1, 1]], dtype=bool)
    assert smallest_conflicts(S, ["a", "b", "c"]) == [["a", "b", "c"]]


def test_largest_consistent_subset_prefers_size_then_support():
    S = np.array([[1, 1, 0], [1, 1, 0], [0, 1, 1]], dtype=bool)
    assert _largest_consistent(S).tolist() == [True, True, False]


def _facts(S, log_err):
    n_num = log_err.shape[1]
    names = tuple(f"up:r{j}" for j in range(S.shape[1] - n_num)) + tuple(
        f"num:k{j}" for j in range(n_num))
    return Facts(names, S, log_err)


def test_condition_accepts_only_consistent_and_map_is_closest():
    ev = load_evidence()
    rng = np.random.default_rng(1)
    n = 400
    x = rng.uniform(0, 1, n)  # one unknown that decides standing
    up = x < 0.5
    err = np.column_stack([rng.normal(0, 0.3, n), rng.normal(0, 0.3, n)])
    within = np.abs(err) <= np.log(1.5)
    S = np.column_stack([up, within])
    post = condition(_facts(S, err), {"x": x}, {"x": (0.0, 1.0)}, ev)
    assert post.accepted.tolist() == (up & within.all(axis=1)).tolist()
    assert not post.conflicts and not post.dropped
    d = np.where(post.accepted, np.sum(err**2, axis=1), np.inf)
    assert post.map_index == int(np.argmin(d))
    m = post.marginals["x"]
    assert m["q95"] < 0.5 and m["identified"]  # half the range: width ratio ~0.5 or less


def test_condition_conflict_uses_largest_subset():
    ev = load_evidence()
    S = np.array([[1, 0, 1], [0, 1, 1], [1, 0, 0]], dtype=bool)
    err = np.zeros((3, 1))
    post = condition(_facts(S, err), {"x": np.arange(3.0)}, {"x": (0.0, 2.0)}, ev)
    assert post.conflicts == (("up:r0", "up:r1"),)
    assert post.used == ("up:r0", "num:k0") and post.dropped == ("up:r1",)
    assert post.accepted.tolist() == [True, False, False]


def test_auc_known_values():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    assert auc(x, np.array([False, False, True, True])) == 1.0
    assert auc(x, np.array([True, True, False, False])) == 0.0
    assert auc(x, np.array([True, False, False, True])) == pytest.approx(0.5)
    assert auc(x, np.array([True, False, True, False])) == pytest.approx(0.25)


def test_judge_verdicts_and_deciding_parameter():
    from mwip.calibration import claims as C

    n = 200
    rng = np.random.default_rng(3)
    g = rng.uniform(3.7, 51, n)
    other = rng.uniform(0, 1, n)
    acc = np.ones(n, dtype=bool)
    keys = [c.key for c in C.CLAIMS]
    verdicts = {k: np.ones(n, dtype=bool) for k in keys}
    verdicts[keys[1]] = np.zeros(n, dtype=bool)
    verdicts[keys[2]] = g < 20
    out = {e["study"] + "/" + e["id"]: e for e in
           judge(verdicts, acc, {"gear": g, "other": other}, 0, 0.95)}
    assert out[keys[0]]["verdict"] == "holds"
    assert out[keys[1]]["verdict"] == "fails"
    u = out[keys[2]]
    assert u["verdict"] == "undecided"
    assert u["decided_by"]["parameter"] == "gear" and u["decided_by"]["holds_when"] == "smaller"
    assert u["interval"][0] < u["fraction"] < u["interval"][1]
