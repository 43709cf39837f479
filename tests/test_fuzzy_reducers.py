"""Type reducers against closed forms and an independent implementation (pyit2fls)."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.fuzzy.reducers import bmm, karnik_mendel, km_output, nie_tan, weighted_average

try:  # test-only reference implementation
    import pyit2fls as _p2

    HAVE_PYIT2FLS = True
except Exception:  # pragma: no cover - depends on the environment
    HAVE_PYIT2FLS = False

needs_pyit2fls = pytest.mark.skipif(
    not HAVE_PYIT2FLS, reason="pyit2fls (test-only reference type reducers) is not importable"
)


def _random_rule_bases(seed: int, n_cases: int = 200, max_rules: int = 12):
    rng = np.random.default_rng(seed)
    for _ in range(n_cases):
        n = int(rng.integers(2, max_rules + 1))
        y_lo = rng.normal(0.0, 2.0, n)
        y_hi = y_lo + rng.uniform(0.0, 1.0, n)
        f_hi = rng.uniform(0.05, 1.0, n)
        f_lo = f_hi * rng.uniform(0.0, 1.0, n)
        yield y_lo, y_hi, f_lo, f_hi


def test_closed_forms_and_degenerate_cases():
    f = np.array([0.2, 0.5, 0.3])
    y = np.array([-1.0, 0.0, 2.0])
    assert weighted_average(f, y) == pytest.approx(0.4)
    # equal lower and upper firing: every reducer is the type-1 weighted average
    for out in (nie_tan(f, f, y), bmm(f, f, y), km_output(f, f, y)):
        assert out == pytest.approx(0.4)
    # nothing fires: 0, not NaN
    z = np.zeros(3)
    for out in (nie_tan(z, z, y), bmm(z, z, y), km_output(z, z, y)):
        assert out == 0.0
    with pytest.raises(ValueError, match="lower <= upper"):
        nie_tan(f + 0.1, f, y)


def test_km_bounds_contain_nt_and_bmm_and_batch_matches_loop():
    rng = np.random.default_rng(3)
    f_hi = rng.uniform(0.1, 1.0, (50, 9))
    f_lo = f_hi * rng.uniform(0.0, 1.0, (50, 9))
    y = rng.normal(size=(50, 9))
    yl, yr = karnik_mendel(f_lo, f_hi, y)
    assert np.all(yl <= nie_tan(f_lo, f_hi, y) + 1e-12)
    assert np.all(nie_tan(f_lo, f_hi, y) <= yr + 1e-12)
    assert np.all((yl <= bmm(f_lo, f_hi, y) + 1e-12) & (bmm(f_lo, f_hi, y) <= yr + 1e-12))
    loop = np.array([karnik_mendel(f_lo[i], f_hi[i], y[i]) for i in range(50)])
    np.testing.assert_allclose(loop, np.stack([yl, yr], axis=-1), rtol=0, atol=1e-14)


@needs_pyit2fls
def test_karnik_mendel_matches_pyit2fls():
    for y_lo, y_hi, f_lo, f_hi in _random_rule_bases(0):
        ref_l, ref_r = _p2.KM_algorithm(np.column_stack([y_lo, y_hi, f_lo, f_hi]))
        yl, yr = karnik_mendel(f_lo, f_hi, y_lo, y_hi)
        np.testing.assert_allclose([yl, yr], [ref_l, ref_r], rtol=0, atol=1e-9)


@needs_pyit2fls
def test_nie_tan_and_bmm_match_pyit2fls():
    for y_lo, _, f_lo, f_hi in _random_rule_bases(1):
        iv = np.column_stack([y_lo, y_lo, f_lo, f_hi])
        assert nie_tan(f_lo, f_hi, y_lo) == pytest.approx(_p2.NT_algorithm(iv), abs=1e-9)
        for m, n in ((0.5, 0.5), (0.3, 0.7), (1.0, 0.0)):
            if m > 0 and np.sum(f_lo) == 0:
                continue
            ref = _p2.BMM_algorithm(iv, [m, n])
            assert bmm(f_lo, f_hi, y_lo, m, n) == pytest.approx(ref, abs=1e-9)
