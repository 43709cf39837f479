"""Compiled scalar forms of the NumPy functions the twin's elements use, with NumPy's
semantics: ``np.sign`` (0.0 for either zero, NaN for NaN), ``np.maximum`` / ``np.minimum``
(NaN propagates), ``np.clip`` (``minimum(maximum(x, lo), hi)``) and ``np.nan_to_num``."""

from __future__ import annotations

import math

import numpy as np

from mwip.jit_cache import njit

__all__ = ["sign", "maximum", "minimum", "clip", "nan_to_num"]

_MAXF = float(np.finfo(np.float64).max)


@njit(inline="always")
def sign(x):  # noqa: ANN001, ANN201 - compiled kernel
    """``np.sign`` of a float."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x if x != x else 0.0


@njit(inline="always")
def maximum(a, b):  # noqa: ANN001, ANN201 - compiled kernel
    """``np.maximum`` of two floats (NaN propagates)."""
    return a if (a >= b or a != a) else b


@njit(inline="always")
def minimum(a, b):  # noqa: ANN001, ANN201 - compiled kernel
    """``np.minimum`` of two floats (NaN propagates)."""
    return a if (a <= b or a != a) else b


@njit(inline="always")
def clip(x, lo, hi):  # noqa: ANN001, ANN201 - compiled kernel
    """``np.clip(x, lo, hi)`` = ``minimum(maximum(x, lo), hi)``."""
    return minimum(maximum(x, lo), hi)


@njit(inline="always")
def nan_to_num(x):  # noqa: ANN001, ANN201 - compiled kernel
    """``np.nan_to_num`` of a float."""
    if x != x:
        return 0.0
    if x == math.inf:
        return _MAXF
    if x == -math.inf:
        return -_MAXF
    return x
