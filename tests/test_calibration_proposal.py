"""Stage 2 of the book calibration (mwip.calibration.proposal): the box proposal pooled with
prior draws under the balance heuristic estimates the prior's expectations without bias, and
the weighted consistent draws recover a known posterior far more precisely than prior draws
alone."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mwip.calibration.posterior import weighted_quantile
from mwip.calibration.proposal import BoxProposal, inside, mis_weights, sample_box

NAMES = ["a", "b", "c"]
BOUNDS = np.array([[0.0, 1.0], [0.0, 2.0], [5.0, 5.0]])  # c fixed by the prior (low = high)
BOX = BoxProposal(draws=4000, seed=3, box={"a": (0.0, 0.2), "b": (0.0, 0.5)})


def _pool(n_prior: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    xp = BOUNDS[:, 0] + rng.random((n_prior, 3)) * (BOUNDS[:, 1] - BOUNDS[:, 0])
    got = sample_box(BOX, NAMES, BOUNDS, lambda v: {"y": v["a"]}, block=1000)
    xb = got[[f"param.{n}" for n in NAMES]].to_numpy()
    x = np.vstack([xp, xb])
    w = mis_weights(inside(x, BOX.ranges(NAMES, BOUNDS)), n_prior, len(xb),
                    BOX.fraction(NAMES, BOUNDS))  # fmt: skip
    return x, w


def test_box_fraction_and_draws_inside_the_box() -> None:
    assert BOX.fraction(NAMES, BOUNDS) == pytest.approx(0.2 * 0.25)
    got = sample_box(BOX, NAMES, BOUNDS, lambda v: {"y": v["a"] * 0}, block=1500)
    x = got[[f"param.{n}" for n in NAMES]].to_numpy()
    assert len(got) == 4000 and np.all(inside(x, BOX.ranges(NAMES, BOUNDS)))
    assert np.all(x[:, 2] == 5.0) and got["sample"].min() >= 10**9
    # deterministic and independent of the block size
    again = sample_box(BOX, NAMES, BOUNDS, lambda v: {"y": v["a"] * 0}, block=333)
    pd.testing.assert_frame_equal(got, again)


def test_pooled_weights_estimate_prior_expectations_without_bias() -> None:
    x, w = _pool(2000)
    # E_prior[1{a < 0.1}] = 0.1, E_prior[a] = 0.5, E_prior[1{a < 0.1, b < 0.25}] = 0.0125
    for f, truth in ((x[:, 0] < 0.1, 0.1), (x[:, 0], 0.5),
                     ((x[:, 0] < 0.1) & (x[:, 1] < 0.25), 0.0125)):  # fmt: skip
        est = np.sum(w * f) / np.sum(w)
        assert est == pytest.approx(truth, rel=0.06, abs=0.004)
    assert np.mean(w) == pytest.approx(1.0, rel=0.05)


def test_the_weighted_posterior_of_a_small_region_is_uniform() -> None:
    """Posterior: the prior restricted to a in [0.05, 0.15], b in [0.1, 0.3] (1 % of the
    box): 20 of 2,000 prior draws expected, ~650 of the pool; the pool gives its quantiles."""
    x, w = _pool(2000, seed=1)
    ok = (x[:, 0] >= 0.05) & (x[:, 0] <= 0.15) & (x[:, 1] >= 0.1) & (x[:, 1] <= 0.3)
    assert ok[:2000].sum() <= 40 and ok.sum() > 400
    qa = weighted_quantile(x[ok, 0], w[ok], [0.05, 0.5, 0.95])
    qb = weighted_quantile(x[ok, 1], w[ok], [0.05, 0.5, 0.95])
    np.testing.assert_allclose(qa, [0.055, 0.10, 0.145], atol=0.012)
    np.testing.assert_allclose(qb, [0.11, 0.20, 0.29], atol=0.025)


def test_box_entries_are_validated() -> None:
    with pytest.raises(ValueError, match=r"proposal.box.a: \[0, 2\] is not inside"):
        BoxProposal(draws=1, seed=0, box={"a": (0.0, 2.0)}).ranges(NAMES, BOUNDS)
    with pytest.raises(ValueError, match="proposal.box.z: not an unknown"):
        BoxProposal(draws=1, seed=0, box={"z": (0.0, 1.0)}).ranges(NAMES, BOUNDS)
    with pytest.raises(ValueError, match="proposal.box.a: low < high"):
        BoxProposal(draws=1, seed=0, box={"a": (0.5, 0.5)})
    with pytest.raises(ValueError, match="proposal.draws"):
        BoxProposal(draws=-1, seed=0)
