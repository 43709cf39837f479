"""Small statistics for campaign summaries: the Wilson score interval of a success rate.

For ``k`` successes in ``n`` trials, ``p = k / n`` and ``z = 1.959964`` (95 %), the Wilson
interval (Wilson 1927) is

    (p + z^2 / (2n) -+ z sqrt(p (1 - p) / n + z^2 / (4 n^2))) / (1 + z^2 / n),

which, unlike the normal approximation, stays inside [0, 1] and is sensible at k = 0 or n.

>>> lo, hi = wilson(0, 10)
>>> round(lo, 6), round(hi, 4)
(0.0, 0.2775)
"""

from __future__ import annotations

import math

__all__ = ["wilson", "Z95"]

#: The standard normal's 97.5 % quantile.
Z95 = 1.959963984540054


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of the success rate ``k / n`` (``(nan, nan)`` for n = 0)."""
    if n <= 0:
        return math.nan, math.nan
    if not 0 <= k <= n:
        raise ValueError(f"k must be in [0, n={n}], got {k}")
    p = k / n
    den = 1.0 + z * z / n
    mid = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo = 0.0 if k == 0 else max(0.0, (mid - half) / den)  # exact ends: rounding aside
    hi = 1.0 if k == n else min(1.0, (mid + half) / den)
    return lo, hi
