"""Input checks shared by the solvers in :mod:`mwip.linalg`."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def square(name: str, a: ArrayLike, *, complex_ok: bool = True) -> NDArray:
    """``a`` as a finite square 2-D float (or complex) array; ``ValueError`` naming ``name``."""
    arr = np.asarray(a)
    if arr.dtype.kind == "c" and complex_ok:
        arr = arr.astype(np.complex128)
    elif arr.dtype.kind in "biuf":
        arr = arr.astype(np.float64)
    else:
        kind = "real or complex" if complex_ok else "real"
        raise ValueError(f"{name} must be a {kind} numeric array, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name} must be a square 2-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no nan or inf)")
    return arr


def matrix(name: str, a: ArrayLike, rows: int, cols: int | None = None) -> NDArray[np.float64]:
    """``a`` as a finite real 2-D array with ``rows`` rows (and ``cols`` columns if given)."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    arr = arr.astype(np.float64)
    if arr.ndim != 2 or arr.shape[0] != rows or (cols is not None and arr.shape[1] != cols):
        want = f"({rows}, {cols if cols is not None else 'm'})"
        raise ValueError(f"{name} must be a 2-D array of shape {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no nan or inf)")
    return arr
