"""Type reducers for interval type-2 rule bases (Chapter 5).

A rule base fired by an input gives, per rule ``i``, a firing interval ``[f_i, fbar_i]`` and a
consequent value ``y_i`` (a TS consequent, or the centroid of a Mamdani consequent set; for a
consequent with a centroid interval ``[y_i^l, y_i^r]``, Karnik-Mendel takes both ends).
All reducers work on the **last axis** (the rules) and broadcast over leading axes; any number
of rules may be flattened into it.

- :func:`nie_tan` - Nie-Tan, (5.8)/(5.10): ``y = sum (f + fbar) y / sum (f + fbar)``.
- :func:`bmm` - Begian-Melek-Mendel (Section 5.3.2, [38]):
  ``y = m sum f y / sum f + n sum fbar y / sum fbar`` with user weights ``m, n``
  (default ``m = n = 1/2``).
- :func:`karnik_mendel` - the Karnik-Mendel centre-of-sets interval ``[y_l, y_r]`` and its
  midpoint, the textbook reference. The KM iterations converge to the switch point that
  extremises the weighted average; we evaluate that optimum *exactly and without iteration*:
  with the rules sorted by ``y``, ``y_l = min_k (sum_{i<=k} fbar_i y_i + sum_{i>k} f_i y_i) /
  (sum_{i<=k} fbar_i + sum_{i>k} f_i)`` (and the mirror for ``y_r``), all ``k`` at once by
  cumulative sums, which vectorises over the batch. This is the same fixed point the iterative
  KM/EKM algorithms reach (checked against pyit2fls in the tests).
- :func:`weighted_average` - type-1 centre-of-sets / height defuzzification (the T1
  counterparts).

Rule bases that do not fire at all (every denominator zero) return 0 rather than NaN: a
controller that sees nothing commands nothing.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["weighted_average", "nie_tan", "bmm", "karnik_mendel", "km_output"]


def _check(f_lo: ArrayLike, f_hi: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    lo, hi = np.asarray(f_lo, dtype=float), np.asarray(f_hi, dtype=float)
    if np.any(lo < 0) or np.any(lo > hi + 1e-12):
        raise ValueError("firing intervals must satisfy 0 <= lower <= upper")
    return lo, hi


def _safe_ratio(num: NDArray[np.float64], den: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def weighted_average(f: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Type-1 centre-of-sets defuzzification ``sum f y / sum f`` over the last axis."""
    f, y = np.broadcast_arrays(np.asarray(f, dtype=float), np.asarray(y, dtype=float))
    return _safe_ratio(np.sum(f * y, axis=-1), np.sum(f, axis=-1))


def nie_tan(f_lo: ArrayLike, f_hi: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Nie-Tan type reduction and defuzzification, (5.8) and (5.10).

    ``y = sum_i (f_i + fbar_i) / 2 * y_i / sum_j (f_j + fbar_j) / 2``.
    """
    lo, hi = _check(f_lo, f_hi)
    return weighted_average(lo + hi, y)


def bmm(
    f_lo: ArrayLike, f_hi: ArrayLike, y: ArrayLike, m: float = 0.5, n: float = 0.5
) -> NDArray[np.float64]:
    """Begian-Melek-Mendel type reduction (Section 5.3.2, ref. [38]).

    ``y = m * sum f y / sum f + n * sum fbar y / sum fbar``; ``m + n = 1`` keeps the output a
    convex combination (not enforced: the weights are a design choice of the method).
    """
    lo, hi = _check(f_lo, f_hi)
    return m * weighted_average(lo, y) + n * weighted_average(hi, y)


def _km_end(
    f_lo: NDArray[np.float64], f_hi: NDArray[np.float64], y: NDArray[np.float64], left: bool
) -> NDArray[np.float64]:
    order = np.argsort(y, axis=-1, kind="stable")
    ys = np.take_along_axis(y, order, axis=-1)
    lo = np.take_along_axis(f_lo, order, axis=-1)
    hi = np.take_along_axis(f_hi, order, axis=-1)
    # left end: upper firing for the k smallest y, lower for the rest; right end: the mirror.
    first, rest = (hi, lo) if left else (lo, hi)
    zeros = np.zeros((*y.shape[:-1], 1))
    # prefix sums over 0..k (k = -1 .. n-1) of `first`, suffix sums over k+1..n-1 of `rest`
    cf = np.concatenate([zeros, np.cumsum(first, axis=-1)], axis=-1)
    cfy = np.concatenate([zeros, np.cumsum(first * ys, axis=-1)], axis=-1)
    cr = np.concatenate([zeros, np.cumsum(rest, axis=-1)], axis=-1)
    cry = np.concatenate([zeros, np.cumsum(rest * ys, axis=-1)], axis=-1)
    num = cfy + (cry[..., -1:] - cry)
    den = cf + (cr[..., -1:] - cr)
    with np.errstate(divide="ignore", invalid="ignore"):
        cand = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    with np.errstate(invalid="ignore"):
        out = np.nanmin(cand, axis=-1) if left else np.nanmax(cand, axis=-1)
    return np.where(np.isfinite(out), out, 0.0)


def karnik_mendel(
    f_lo: ArrayLike, f_hi: ArrayLike, y_lo: ArrayLike, y_hi: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Karnik-Mendel centre-of-sets type reduction: the interval ``(y_l, y_r)``.

    ``y_lo`` / ``y_hi`` are the left / right centroids of the consequents (``y_hi`` defaults
    to ``y_lo``: crisp consequents). Exact (module docstring), vectorised over leading axes.
    """
    lo, hi = _check(f_lo, f_hi)
    yl = np.asarray(y_lo, dtype=float)
    yr = yl if y_hi is None else np.asarray(y_hi, dtype=float)
    shape = np.broadcast_shapes(lo.shape, hi.shape, yl.shape, yr.shape)
    lo, hi, yl, yr = (np.broadcast_to(a, shape) for a in (lo, hi, yl, yr))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices: no rule fired
        return _km_end(lo, hi, yl, left=True), _km_end(lo, hi, yr, left=False)


def km_output(
    f_lo: ArrayLike, f_hi: ArrayLike, y_lo: ArrayLike, y_hi: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Crisp Karnik-Mendel output ``(y_l + y_r) / 2``."""
    a, b = karnik_mendel(f_lo, f_hi, y_lo, y_hi)
    return 0.5 * (a + b)
