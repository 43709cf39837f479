"""Compiled kernels of the fuzzy library: the two-input Mamdani FLSs of Section 5.3.2
(Tables 5.1-5.2: uniform triangular partitions, minimum t-norm, Begian-Melek-Mendel type
reduction for IT2, the weighted average for type 1) and the PDC membership grades of
Fig. 5.1 / (5.7)-(5.8), one robot per row of a batch.

The one implementation of :meth:`mwip.fuzzy.mamdani.MamdaniFLS.__call__` and
:func:`mwip.fuzzy.ts_model.nie_tan_weights` / ``type1_weights``; the Fig. 5.3 law
(:mod:`mwip.laws.fig53.kernel`) calls them. Their NumPy oracle is in tests/oracle_laws.py;
tests/test_kernels.py holds the two equal on random inputs and benchmarks/mutate_kernels.py
checks that a sign flip here fails them.

Operation order: each membership, firing strength and ratio is computed with the operations
(and operands) of the NumPy building blocks (``sets.triangle``, ``firing_grid``,
``reducers.bmm`` / ``weighted_average``), and the sums over the rules use NumPy's pairwise
summation (:func:`_pairwise`), so an FLS output is bit for bit the one of the NumPy
composition that preceded this kernel.

An FLS is a flat float64 *block* (:meth:`mwip.fuzzy.mamdani.MamdaniFLS.block` writes one):
``[n, t1, m, nw, R1, R2, a1, a2, b]``, then per input the ``n`` apexes, lower-MF feet ``a``,
``c`` and upper-MF feet ``a``, ``c`` (``5 n`` numbers each), then the ``n * n`` consequent
centroids per rule (``[i * n + j]`` for "x1 is A_i and x2 is B_j"): ``9 + 10 n + n^2``
numbers. It evaluates
``y = b * FLS(a1 x1, a2 x2)`` (the scaling that turns the position FLS into the direction FLS,
:func:`mwip.laws.fig53.controller.direction_as_position`; ``1, 1, 1`` for a plain FLS: exact).
"""

from __future__ import annotations

import numpy as np

from mwip.fuzzy.layout import HEAD
from mwip.fuzzy.ts_model import LOWER_HALF_WIDTH, THETA_VERTEX, UPPER_HALF_WIDTH
from mwip.jit_cache import njit  # the kernels' cache follows every kernel source

__all__ = ["HEAD", "fls_eval", "fls_batch", "pdc_weights", "pdc_weights_batch"]


@njit
def _tri(x, a, b, c):  # noqa: ANN001, ANN202 - compiled kernel
    """Triangle ``(a, b, c)`` of height 1 at ``x``, ``a < b < c`` (every set of a
    :class:`~mwip.fuzzy.sets.UniformPartition`), as :func:`mwip.fuzzy.sets.triangle`."""
    v = min((x - a) / (b - a), (c - x) / (c - b))
    return min(max(v, 0.0), 1.0)


@njit
def _block8(a, lo, n):  # noqa: ANN001, ANN202
    """``a[lo : lo + n].sum()`` for ``8 <= n <= 128`` as NumPy's pairwise sum does it: eight
    partial sums over the multiples of 8, combined pairwise, then the rest in order."""
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    m8 = n - n % 8
    for i in range(lo + 8, lo + m8, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(lo + m8, lo + n):
        res += a[i]
    return res


@njit
def _pairwise(a, lo, n):  # noqa: ANN001, ANN202
    """``a[lo : lo + n].sum()`` for ``n >= 8`` in NumPy's pairwise order: above 128 numbers
    the sum of the two halves (the first a multiple of 8), recursively; here with an explicit
    stack of segments (numba cannot load a cached recursive function) and bounded loops.
    NaN if the stack (64 segments, ``n`` up to 2^60) would overflow."""
    if n <= 128:
        return _block8(a, lo, n)
    seg_lo = np.zeros(64, np.int64)
    seg_n = np.zeros(64, np.int64)
    stage = np.zeros(64, np.int64)  # 0: not split, 1: left half pending, 2: right pending
    left = np.zeros(64)
    top = 0
    seg_lo[0] = lo
    seg_n[0] = n
    for _ in range(2 * n):  # two visits per split segment at most: ends long before
        m = seg_n[top]
        if m > 128 and stage[top] == 0:  # split: push the left half
            half = m // 2
            half -= half % 8
            stage[top] = 1
            lo_top = seg_lo[top]
            top += 1
            if top > 63:
                return np.nan
            seg_lo[top] = lo_top
            seg_n[top] = half
            stage[top] = 0
            continue
        v = _block8(a, seg_lo[top], m)
        top -= 1
        for _ in range(64):  # v completes right halves: add their left ones
            if top < 0 or top > 63 or stage[top] != 2:
                break
            v = left[top] + v
            top -= 1
        if top < 0:
            return v
        if top > 62:
            return np.nan
        left[top] = v  # v completes a left half: push the right one
        stage[top] = 2
        half = seg_n[top] // 2
        half -= half % 8
        seg_lo[top + 1] = seg_lo[top] + half
        seg_n[top + 1] = seg_n[top] - half
        stage[top + 1] = 0
        top += 1
    return np.nan


@njit
def fls_eval(x1, x2, blk, mem, fr):  # noqa: ANN001, ANN201
    """Crisp output ``b * FLS(a1 x1, a2 x2)`` of the FLS ``blk`` (module docstring).

    Inputs saturated to ``[-R, R]``; lower and upper memberships of each set (triangles);
    firing intervals with the minimum t-norm; IT2: BMM ``m sum f y / sum f + nw sum fbar y /
    sum fbar``; type 1: ``sum fbar y / sum fbar`` (a sum of zero gives 0). Scratch: ``mem``
    (4, >= n) the lower / upper memberships of input 1, then input 2; ``fr`` (4, >= n n) the
    lower firing strengths, times the rule outputs, the upper ones, times the outputs."""
    n = int(blk[0])
    t1 = blk[1] != 0.0
    nn = n * n
    z1 = min(max(blk[6] * x1, -blk[4]), blk[4])
    z2 = min(max(blk[7] * x2, -blk[5]), blk[5])
    o1 = HEAD
    o2 = HEAD + 5 * n
    for k in range(n):
        mem[0, k] = _tri(z1, blk[o1 + n + k], blk[o1 + k], blk[o1 + 2 * n + k])
        mem[1, k] = _tri(z1, blk[o1 + 3 * n + k], blk[o1 + k], blk[o1 + 4 * n + k])
        mem[2, k] = _tri(z2, blk[o2 + n + k], blk[o2 + k], blk[o2 + 2 * n + k])
        mem[3, k] = _tri(z2, blk[o2 + 3 * n + k], blk[o2 + k], blk[o2 + 4 * n + k])
    oy = HEAD + 10 * n
    for i in range(n):
        for j in range(n):
            r = i * n + j
            lo = min(mem[0, i], mem[2, j])
            hi = min(mem[1, i], mem[3, j])
            fr[0, r] = lo
            fr[1, r] = lo * blk[oy + r]
            fr[2, r] = hi
            fr[3, r] = hi * blk[oy + r]
    den = 0.0 + _pairwise(fr[2], 0, nn)
    num = 0.0 + _pairwise(fr[3], 0, nn)
    wa_hi = num / den if den > 0.0 else 0.0
    if t1:
        return blk[8] * wa_hi
    den = 0.0 + _pairwise(fr[0], 0, nn)
    num = 0.0 + _pairwise(fr[1], 0, nn)
    wa_lo = num / den if den > 0.0 else 0.0
    return blk[8] * (blk[2] * wa_lo + blk[3] * wa_hi)


@njit
def fls_batch(x1, x2, blk, out):  # noqa: ANN001, ANN201
    """:func:`fls_eval` for every element of ``x1``, ``x2`` (M,) into ``out`` (M,)."""
    mem = np.empty((4, blk.shape[0]))
    fr = np.empty((4, blk.shape[0]))
    for i in range(x1.shape[0]):
        out[i] = fls_eval(x1[i], x2[i], blk, mem, fr)


@njit
def pdc_weights(theta, t1):  # noqa: ANN001, ANN201
    """``(m_1, m_2)`` of the PDC law (5.10) at the measured pitch ``theta``.

    IT2 (``t1`` false): Nie-Tan (5.8) on the memberships of Fig. 5.1 / (5.7) (theta saturated
    to the model's domain ``[-pi/6, pi/6]``): ``lower_1 = max(0, 1 - |theta| / (pi/7))``,
    ``upper_1 = max(0, 1 - |theta| / (pi/6))``, ``M2 = 1 - M1`` on both bounds, and
    ``m_i = (lower_i + upper_i) / sum_j (lower_j + upper_j)``. Type 1: ``m_1`` the triangle at
    the middle of the footprint (half-width ``(pi/7 + pi/6) / 2``), ``m_2 = 1 - m_1``."""
    th = min(max(theta, -THETA_VERTEX), THETA_VERTEX)
    a = abs(th)
    if t1:
        m1 = max(0.0, 1.0 - a / (0.5 * (LOWER_HALF_WIDTH + UPPER_HALF_WIDTH)))
        return m1, 1.0 - m1
    lo1 = max(0.0, 1.0 - a / LOWER_HALF_WIDTH)
    up1 = max(0.0, 1.0 - a / UPPER_HALF_WIDTH)
    w0 = lo1 + up1
    w1 = (1.0 - up1) + (1.0 - lo1)
    s = w0 + w1
    return w0 / s, w1 / s


@njit
def pdc_weights_batch(theta, t1, out):  # noqa: ANN001, ANN201
    """:func:`pdc_weights` for ``theta`` (M,) into ``out`` (M, 2)."""
    for i in range(theta.shape[0]):
        m1, m2 = pdc_weights(theta[i], t1)
        out[i, 0] = m1
        out[i, 1] = m2
