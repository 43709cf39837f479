"""Stage 4's box-kernel mixture and the balance-heuristic pool (mwip.calibration.mixture),
against exact answers: the density of clipped boxes, the law of the draws on a test box, and
a pooled importance-sampling estimate of a set whose volume and centre are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mwip.calibration.mixture import KernelMixture, MixturePlan, balance_weights, prior_density

UNIT3 = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])


def test_density_of_one_box_and_of_a_clipped_one():
    b = np.array([[0.0, 2.0], [0.0, 1.0], [5.0, 5.0]])  # the last unknown fixed by the prior
    seeds = np.array([[1.0, 0.5, 5.0], [0.0, 0.5, 5.0], [1.5, 0.1, 5.0]])
    q = KernelMixture.fit(seeds, b, [0.2])
    sd = seeds.std(axis=0)
    h = 0.2 * sd[:2]
    # component 0 is inside the box; component 1 sits on the wall x = 0: half its box is cut
    assert q.volumes[0] == pytest.approx(4 * h[0] * h[1])
    assert q.volumes[1] == pytest.approx(2 * h[0] * h[1])
    assert not q.free[2] and np.all(q.lo[:, 2] == 5.0) and np.all(q.hi[:, 2] == 5.0)
    inside0 = np.array([[1.0 + 0.5 * h[0], 0.5, 5.0]])
    assert q.density(inside0)[0] == pytest.approx(1 / 3 / q.volumes[0])
    assert q.density(np.array([[1.0 + 1.01 * h[0], 0.5, 5.0]]))[0] == 0.0
    assert prior_density(b) == pytest.approx(0.5)


def test_draws_follow_the_density_and_do_not_depend_on_the_blocks():
    rng = np.random.default_rng(3)
    seeds = rng.random((5, 3)) ** 2  # crowded near a corner: many boxes are clipped
    q = KernelMixture.fit(seeds, UNIT3, [0.5, 2.0])
    n = 40_000
    x = q.draw(11, range(n))
    assert np.all((x >= 0) & (x <= 1))
    a_lo, a_hi = np.array([0.0, 0.05, 0.1]), np.array([0.3, 0.4, 0.6])
    # exact P_q(A): sum_k pi_k |B_k n A| / |B_k|
    over = np.clip(np.minimum(q.hi, a_hi) - np.maximum(q.lo, a_lo), 0.0, None)
    exact = float(np.sum(q.pi * np.prod(over, axis=1) / q.volumes))
    got = float(np.mean(np.all((x >= a_lo) & (x <= a_hi), axis=1)))
    assert abs(got - exact) < 4 * math.sqrt(exact * (1 - exact) / n)
    # E_q[1/q] over the support = its volume; here the support is inside the unit cube
    assert np.mean(1.0 / q.density(x[:5000])) <= 1.0 + 0.05
    np.testing.assert_array_equal(q.draw(11, [7, 8, 9]), x[7:10])


def test_the_pooled_estimate_of_a_ball_is_unbiased():
    """Synthetic truth: F a ball of radius 0.15 at (0.6, 0.4, 0.5) in the unit cube (volume
    4/3 pi r^3, centre known). Stage 1: uniform draws; stage 4: a mixture fitted to the
    stage-1 draws inside F. The pooled weights estimate P(F) and F's centre."""
    c, r = np.array([0.6, 0.4, 0.5]), 0.15
    vol = 4 / 3 * math.pi * r**3
    rng = np.random.default_rng(5)
    n1, n4 = 4000, 6000
    x1 = rng.random((n1, 3))
    hit1 = np.linalg.norm(x1 - c, axis=1) <= r
    assert 20 <= hit1.sum() <= 80
    q = KernelMixture.fit(x1[hit1], UNIT3, [0.5, 1.0])
    x4 = q.draw(2, range(n4))
    x = np.vstack([x1, x4])
    p = np.full(len(x), prior_density(UNIT3))
    w = balance_weights(p, [n1, n4], [p, q.density(x)])
    assert np.all(w <= (n1 + n4) / n1 + 1e-12)
    f = np.linalg.norm(x - c, axis=1) <= r
    est = np.mean(w * f)
    se = np.std(w * f) / math.sqrt(len(x))
    assert abs(est - vol) < 4 * se and se < 0.1 * vol  # precise, and right
    centre = np.sum((w * f)[:, None] * x, axis=0) / np.sum(w * f)
    np.testing.assert_allclose(centre, c, atol=0.01)
    # the pool's mean weight estimates 1 (the prior's total mass)
    assert abs(np.mean(w) - 1.0) < 4 * np.std(w) / math.sqrt(len(x))


def test_balance_weights_reduce_to_the_prior_alone():
    p = np.full(10, 0.25)
    np.testing.assert_allclose(balance_weights(p, [10], [p]), 1.0)


@pytest.mark.parametrize("kw, field", [
    ({"draws": -1}, "mixture.draws"), ({"draws": True}, "mixture.draws"),
    ({"seed": -3}, "mixture.seed"), ({"factors": ()}, "mixture.factors"),
    ({"factors": (0.0,)}, "mixture.factors"), ({"effective": 0.5}, "mixture.effective"),
])  # fmt: skip
def test_plan_validation_names_the_field(kw, field):
    base = {"draws": 10, "seed": 1, "factors": (1.0,), "effective": 10.0}
    with pytest.raises(ValueError, match=field):
        MixturePlan(**{**base, **kw})


def test_seeds_outside_the_prior_are_refused():
    with pytest.raises(ValueError, match="outside the prior box"):
        KernelMixture.fit(np.array([[1.5, 0.5, 0.5]]), UNIT3, [1.0])


@pytest.mark.parametrize("kw, field", [
    ({"draws": -1}, "envelope.draws"), ({"draws": 2.5}, "envelope.draws"),
    ({"seed": -1}, "envelope.seed"),
])  # fmt: skip
def test_envelope_plan_validation_names_the_field(kw, field):
    from mwip.calibration.mixture import EnvelopePlan

    with pytest.raises(ValueError, match=field):
        EnvelopePlan(**{"draws": 10, "seed": 1, **kw})


def test_the_envelope_is_the_bounding_box_and_its_draws_are_uniform():
    pts = np.array([[0.2, 0.5, 0.1], [0.4, 0.5, 0.3], [0.3, 0.5, 0.2]])
    e = KernelMixture.envelope(pts, UNIT3)
    np.testing.assert_allclose(e.lo[0], [0.2, 0.4995, 0.1])  # agreeing unknown: 1e-3 wide
    np.testing.assert_allclose(e.hi[0], [0.4, 0.5005, 0.3])
    assert e.volumes[0] == pytest.approx(0.2 * 1e-3 * 0.2)
    x = e.draw(4, range(2000))
    assert np.all((x >= e.lo[0]) & (x <= e.hi[0]))
    np.testing.assert_allclose(e.density(x), 1.0 / e.volumes[0])
    assert abs(np.mean(x[:, 0]) - 0.3) < 4 * 0.2 / np.sqrt(12 * 2000)
