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
        assert s.centroid_interval == (s.lower.b, s.lower.b)
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
