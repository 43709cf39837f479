"""Performance measures of time series (SPEC.md section 6).

All functions take a time vector ``t`` (K,) and a series ``x`` (K,) or (..., K) and ignore NaN
rows (records after a plant stopped).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["rms", "settling_time", "total_variation_rate", "overshoot"]


def _window(t: NDArray[np.float64], window: tuple[float, float] | None) -> NDArray[np.bool_]:
    if window is None:
        return np.ones(t.shape, dtype=bool)
    return (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)


def rms(
    t: ArrayLike, x: ArrayLike, window: tuple[float, float] | None = None
) -> NDArray[np.float64]:
    """Root mean square of the samples of ``x`` inside ``window``, (6.3): sqrt(mean(x^2))."""
    tt = np.asarray(t, dtype=float)
    xx = np.asarray(x, dtype=float)[..., _window(tt, window)]
    return np.sqrt(np.nanmean(xx**2, axis=-1))


def settling_time(
    t: ArrayLike,
    x: ArrayLike,
    band: float | None = None,
    *,
    rel: float = 0.02,
    atol: float = 1e-3,
    status: str = "ok",
) -> float:
    """Time after which ``|x|`` stays within ``band`` until the end of the record.

    Default band: ``max(rel * max|x|, atol)`` (2 % of the peak, at least 1 mrad for angles).
    Returns ``nan`` (shown "n/a") when the series never settles (it ends outside the band or
    is all NaN) and whenever the run did not end ``ok`` (``status`` ``"fell"`` or
    ``"diverged"``): a run that stopped has not settled, even if the records it left (cut at
    the stop) happen to lie inside the band, e.g. a diverged wheel mode under a small pitch.
    """
    if status != "ok":
        return float("nan")
    tt = np.asarray(t, dtype=float)
    xx = np.abs(np.asarray(x, dtype=float))
    ok = np.isfinite(xx)
    if not ok.any() or not ok[-1]:
        return float("nan")
    tt, xx = tt[ok], xx[ok]
    if band is None:
        band = max(rel * float(np.max(xx)), atol)
    outside = np.nonzero(xx > band)[0]
    if outside.size == 0:
        return float(tt[0])
    last = outside[-1]
    if last == xx.size - 1:
        return float("nan")
    return float(tt[last + 1])


def total_variation_rate(t: ArrayLike, x: ArrayLike) -> NDArray[np.float64]:
    """Total variation per second, ``sum |x_{k+1} - x_k| / (t_end - t_0)`` (chattering index)."""
    tt = np.asarray(t, dtype=float)
    xx = np.asarray(x, dtype=float)
    dx = np.abs(np.diff(xx, axis=-1))
    return np.nansum(dx, axis=-1) / (tt[-1] - tt[0])


def overshoot(x: ArrayLike, x0: float | None = None) -> float:
    """Largest excursion of ``x`` to the side opposite its initial value (rad)."""
    xx = np.asarray(x, dtype=float)
    start = float(xx[0]) if x0 is None else x0
    if start == 0:
        return float(np.nanmax(np.abs(xx)))
    opposite = -np.sign(start) * xx
    return float(max(np.nanmax(opposite), 0.0))
