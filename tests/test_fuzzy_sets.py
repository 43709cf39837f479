"""Triangular type-1 / IT2 sets, partitions, t-norm and rule firing."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.fuzzy.sets import (
    TriangularIT2Set,
    TriangularSet,
    UniformPartition,
    firing_grid,
    min_tnorm,
    triangle,
)

try:
    import pyit2fls as _p2
except Exception:  # pragma: no cover
    _p2 = None


def test_triangle_values_and_shoulders():
    x = np.array([-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(triangle(x, -1, 0, 1), [0, 0, 0.5, 1, 0.5, 0, 0])
    np.testing.assert_allclose(triangle(x, 0, 0, 1), [0, 0, 0, 1, 0.5, 0, 0])
    np.testing.assert_allclose(triangle(x, -1, 0, 0), [0, 0, 0.5, 1, 0, 0, 0])


@pytest.mark.skipif(_p2 is None, reason="pyit2fls (test-only reference) is not importable")
def test_triangle_matches_pyit2fls():
    x = np.random.default_rng(0).uniform(-3, 3, 500)
    for a, b, c in ((-1.0, 0.2, 1.5), (-2.0, -1.0, 0.0), (0.0, 1.0, 2.5)):
        np.testing.assert_allclose(triangle(x, a, b, c), _p2.tri_mf(x, [a, b, c, 1.0]), atol=1e-12)


def test_sets_validate_themselves():
    with pytest.raises(ValueError, match="a <= b <= c"):
        TriangularSet(1.0, 0.0, 2.0)
    with pytest.raises(ValueError, match="under upper"):
        TriangularIT2Set(TriangularSet(-2, 0, 2), TriangularSet(-1, 0, 1))
    with pytest.raises(ValueError, match="fou"):
        UniformPartition(1.0, fou=0.6)
    with pytest.raises(ValueError, match="odd"):
        UniformPartition(1.0, n=6, labels=tuple("abcdef"))


def test_partition_lower_under_upper_cover_and_type1_counterpart():
    part = UniformPartition(3.0)
    x = np.linspace(-4, 4, 801)
    lo, up = part.memberships(x)
    assert lo.shape == up.shape == (801, 7)
    assert np.all(lo <= up + 1e-15)
    assert np.all(lo.sum(-1) > 0.3)  # the lower MFs cover the range: BMM is always defined
    t1_lo, t1_up = part.type1().memberships(x)
    np.testing.assert_array_equal(t1_lo, t1_up)
    np.testing.assert_allclose(t1_lo.sum(-1), 1.0)  # partition of unity
    # the type-1 set is the middle of each footprint
    for s, s1 in zip(part.sets(), part.type1().sets(), strict=True):
        assert s.middle() == s1.upper
        cl, cr = s.centroid_interval  # symmetric about the apex, strictly inside the support
        assert cl == pytest.approx(2 * s.lower.b - cr, abs=1e-12) and cl < s.lower.b < cr
    # every object evaluation agrees with the vectorised one
    objs = np.stack([np.stack(s(part.clip(x)), -1) for s in part.sets()], axis=1)
    np.testing.assert_allclose(objs[..., 0], lo)
    np.testing.assert_allclose(objs[..., 1], up)


def test_min_tnorm_and_firing_grid():
    assert min_tnorm([0.2, 0.9], [0.5, 0.4], [0.3, 1.0]).tolist() == [0.2, 0.4]
    l1, u1 = np.array([[0.1, 0.6]]), np.array([[0.3, 0.8]])
    l2, u2 = np.array([[0.5, 0.2, 0.0]]), np.array([[0.7, 0.4, 0.1]])
    flo, fhi = firing_grid(l1, u1, l2, u2)
    assert flo.shape == (1, 2, 3)
    np.testing.assert_allclose(flo[0], [[0.1, 0.1, 0.0], [0.5, 0.2, 0.0]])
    np.testing.assert_allclose(fhi[0], [[0.3, 0.3, 0.1], [0.7, 0.4, 0.1]])


def _centroid_brute_force(s: TriangularIT2Set, n: int = 400_001) -> tuple[float, float]:
    """Independent check: every switch point of a dense grid, min / max of the centroids."""
    x = np.linspace(s.upper.a, s.upper.c, n)
    lo, up = s(x)
    out = []
    for left, right, pick in ((up, lo, np.min), (lo, up, np.max)):
        num = np.cumsum(left * x) + (np.sum(right * x) - np.cumsum(right * x))
        den = np.cumsum(left) + (np.sum(right) - np.cumsum(right))
        out.append(float(pick(num / den)))
    return out[0], out[1]


_CENTROID_SETS = [
    ((-0.5, 0.0, 0.5, 1.0), (-1.0, 0.0, 1.0, 1.0)),  # symmetric: KM gives +-0.16771
    ((-0.2, 0.3, 0.5, 0.6), (-1.0, 0.3, 2.0, 1.0)),  # asymmetric, lower height 0.6
    ((0.0, 1.0, 1.0, 1.0), (-1.0, 1.0, 1.5, 1.0)),  # right shoulder in the lower MF
    ((-3.0, -2.0, 0.0, 0.3), (-3.5, -2.0, 0.5, 0.9)),
]


@pytest.mark.parametrize(("lower", "upper"), _CENTROID_SETS)
def test_centroid_interval_karnik_mendel(lower, upper):
    """The centroid interval is the Karnik-Mendel one, not the apex (it was ``(b, b)``)."""
    s = TriangularIT2Set(TriangularSet(*lower), TriangularSet(*upper))
    cl, cr = s.centroid_interval
    n = 400_001
    bl, br = _centroid_brute_force(s, n)
    h = (upper[2] - upper[0]) / (n - 1)  # the oracle's Riemann sums err by O(h) at a jump
    assert cl == pytest.approx(bl, abs=4 * h) and cr == pytest.approx(br, abs=4 * h)
    # every embedded set's centroid lies inside: the lower and the upper MF's own centroids
    for t in (s.lower, s.upper):
        assert cl - 1e-12 <= t.centroid <= cr + 1e-12
    assert cl < cr


def test_centroid_interval_symmetric_value():
    s = TriangularIT2Set(TriangularSet(-0.5, 0.0, 0.5), TriangularSet(-1.0, 0.0, 1.0))
    cl, cr = s.centroid_interval
    assert cl == pytest.approx(-0.167715, abs=1e-6) and cr == pytest.approx(0.167715, abs=1e-6)


@pytest.mark.skipif(_p2 is None, reason="pyit2fls (test-only reference) is not importable")
@pytest.mark.parametrize(("lower", "upper"), _CENTROID_SETS)
def test_centroid_interval_matches_pyit2fls(lower, upper):
    """pyit2fls's KM (and EKM) on a fine discretisation converge to our exact interval."""
    s = TriangularIT2Set(TriangularSet(*lower), TriangularSet(*upper))
    d = np.linspace(upper[0], upper[2], 20001)
    ref = _p2.IT2FS(d, _p2.tri_mf, list(upper), _p2.tri_mf, list(lower))
    for alg in (_p2.KM_algorithm, _p2.EKM_algorithm):
        km = _p2.Centroid(ref, alg, d)
        np.testing.assert_allclose(s.centroid_interval, km, atol=2e-4)


def test_centroid_interval_degenerate_sets():
    one = TriangularSet(0.5, 0.5, 0.5)
    assert TriangularIT2Set(one, one).centroid_interval == (0.5, 0.5)
    # a singleton lower MF has zero area: the embedded sets span the upper support
    s = TriangularIT2Set(TriangularSet(0.0, 0.0, 0.0), TriangularSet(-1.0, 0.0, 2.0))
    assert s.centroid_interval == (-1.0, 2.0)
