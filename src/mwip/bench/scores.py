"""The scores: per entrant, axis and level, the success fraction with its Wilson 95 % interval
and the medians of the performance metrics over the successful runs.

For ``k`` successes of ``n`` runs: ``fraction = k / n`` and the Wilson score interval
(:func:`mwip.campaign.stats.wilson`). A row with ``level = "(all)"`` pools the axis's levels
(``n`` = levels x samples). The metric medians (``rms_theta`` (6.3), ``rms_speed_error``,
``control_tv``, ``peak_torque``; :mod:`mwip.campaign.metrics`) are over the successful runs
only (NaN when none succeeded).

The leaderboard's ``score`` of an entrant is the mean of its pooled fractions over the axes
other than ``nominal`` (each axis weighs the same, whatever its number of levels); ties are
broken by the nominal fraction, then by the median RMS theta of the nominal runs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.bench.spec import Bench
from mwip.campaign.stats import wilson

__all__ = ["PERFORMANCE", "POOLED", "score_table", "leaderboard"]

#: The performance metrics reported (medians over the successful runs).
PERFORMANCE: tuple[str, ...] = ("rms_theta", "rms_speed_error", "control_tv", "peak_torque")
#: The ``level`` of a row that pools an axis's levels.
POOLED = "(all)"


def _row(controller: str, axis: str, level: str, part: Any) -> dict[str, Any]:
    n = int(len(part))
    k = int(part["success"].sum())
    lo, hi = wilson(k, n)
    ok = part[part["success"]]
    row: dict[str, Any] = {"controller": controller, "axis": axis, "level": level, "n": n,
                           "successes": k, "fraction": k / n if n else np.nan,
                           "wilson_lo": lo, "wilson_hi": hi}  # fmt: skip
    for m in PERFORMANCE:
        row[f"median_{m}"] = float(ok[m].median()) if len(ok) else np.nan
    return row


def score_table(results: Any, bench: Bench, labels: list[str]) -> Any:
    """``scores.parquet``: one row per entrant x axis x level (file order), then per entrant
    x axis pooled (``level = "(all)"``), from ``results.parquet`` of the run."""
    import pandas as pd

    rows = []
    groups = {key: part for key, part in results.groupby(["controller", "axis", "level"],
                                                         sort=False)}  # fmt: skip
    empty = results.iloc[0:0]
    for c in labels:
        for ax in bench.axes:
            parts = []
            for lv in ax.levels:
                part = groups.get((c, ax.name, lv.label), empty)
                parts.append(part)
                rows.append(_row(c, ax.name, lv.label, part))
            rows.append(_row(c, ax.name, POOLED, pd.concat(parts, ignore_index=True)))
    return pd.DataFrame(rows)


def leaderboard(scores: Any, bench: Bench) -> Any:
    """Per entrant: ``score`` (module docstring), each axis's pooled fraction and interval,
    ranked best first."""
    import pandas as pd

    pooled = scores[scores["level"] == POOLED]
    out = []
    for c, part in pooled.groupby("controller", sort=False):
        by = part.set_index("axis")
        row: dict[str, Any] = {"controller": c}
        others = [a.name for a in bench.axes if a.name != "nominal"]
        row["score"] = float(by.loc[others, "fraction"].mean()) if others else np.nan
        for a in bench.axes:
            row[a.name] = float(by.loc[a.name, "fraction"])
            row[f"{a.name}_lo"] = float(by.loc[a.name, "wilson_lo"])
            row[f"{a.name}_hi"] = float(by.loc[a.name, "wilson_hi"])
        nominal = scores[(scores["controller"] == c) & (scores["axis"] == bench.axes[0].name)
                         & (scores["level"] == POOLED)]  # fmt: skip
        for m in PERFORMANCE:
            row[f"median_{m}"] = float(nominal[f"median_{m}"].iloc[0])
        out.append(row)
    df = pd.DataFrame(out)
    first = bench.axes[0].name
    df["_rms"] = df["median_rms_theta"].fillna(np.inf)
    df = df.sort_values(["score", first, "_rms"], ascending=[False, False, True], kind="stable")
    return df.drop(columns="_rms").reset_index(drop=True)
