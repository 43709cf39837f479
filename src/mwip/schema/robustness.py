"""A claims campaign's verdicts, as the report reads them: per claim, the fraction of
plausible settings under which it holds, with its Wilson 95 % interval.

The table is ``results.parquet`` of a claims campaign (:mod:`mwip.campaign.claims`, one row per
study, sample and claim: ``study``, ``claim``, ``book``, ``holds``, ``error``, ...).

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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "Z95", "wilson", "ClaimRobustness", "claim_robustness", "load_claim_robustness",
    "robustness_text",
]  # fmt: skip

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


@dataclass(frozen=True)
class ClaimRobustness:
    """A claim's verdict over its plausible settings: holds in ``k`` of ``n`` draws,
    ``fraction = k / n`` with the Wilson 95 % interval ``[lo, hi]``."""

    study: str
    claim: str
    book: str
    k: int
    n: int
    fraction: float
    lo: float
    hi: float


def claim_robustness(results: Any) -> dict[tuple[str, str], ClaimRobustness]:
    """Per (study, claim id): the verdicts of a claims campaign's table (errors excluded:
    rows with an ``error`` or no ``holds``)."""
    df = results[(results["error"] == "") & results["holds"].notna()]
    out: dict[tuple[str, str], ClaimRobustness] = {}
    for (study, claim), g in df.groupby(["study", "claim"], sort=False):
        k, n = int(g["holds"].astype(bool).sum()), int(len(g))
        lo, hi = wilson(k, n)
        out[(str(study), str(claim))] = ClaimRobustness(
            str(study), str(claim), str(g["book"].iloc[0]), k, n, k / n, lo, hi
        )
    return out


def load_claim_robustness(folder: str | Path) -> dict[tuple[str, str], ClaimRobustness]:
    """:func:`claim_robustness` of ``folder/results.parquet`` (a finished claims campaign)."""
    import pandas as pd

    df = pd.read_parquet(Path(folder) / "results.parquet")
    missing = {"study", "claim", "book", "holds", "error"} - set(df.columns)
    if missing:
        raise ValueError(f"--claims: {str(folder)!r} holds no claims campaign (its table lacks "
                         f"{', '.join(sorted(missing))}); give `mwip campaign run claims`'s "
                         "folder")  # fmt: skip
    return claim_robustness(df)


def robustness_text(
    table: dict[tuple[str, str], ClaimRobustness], study: str, claim: dict[str, Any]
) -> str:
    """What the main report shows beside ``claim`` (a claim of ``study``'s metrics document):
    ``"holds in 75 % of plausible settings (95 % interval 62-85 %, n = 40)"``, or ``""`` when
    the campaign has no verdicts for it."""
    key = (study, str(claim.get("id") or claim.get("text", "")))
    r = table.get(key)
    if r is None or r.n == 0:
        return ""
    return (
        f"holds in {100 * r.fraction:.0f} % of plausible settings "
        f"(95 % interval {100 * r.lo:.0f}-{100 * r.hi:.0f} %, n = {r.n})"
    )
