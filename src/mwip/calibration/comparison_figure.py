"""The comparison's figure (``structures.png``, from the document of
:func:`mwip.calibration.comparison.analyse_table`): per structure, each unknown's twins found
meeting its largest consistent subset as their 5-95 % range and median, in the prior's unit
coordinates (where the prior is uniform on ``[0, 1]``; log-uniform unknowns on their log),
so that a range piled at a wall or narrowed by the facts shows at a glance. Drawn from the
document alone, so ``--replay`` redraws it byte for byte."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

__all__ = ["figure"]

#: The outer share of a prior's range called its wall (as :data:`comparison.WALL`).
WALL = 0.05


def _unit(x: float, m: dict[str, Any]) -> float:
    lo, hi = m["prior"]
    if hi <= lo:
        return 0.0
    if m["scale"] == "log":
        return (math.log(x) - math.log(lo)) / (math.log(hi) - math.log(lo))
    return (x - lo) / (hi - lo)


def figure(doc: dict[str, Any], path: Path) -> None:
    """Write ``structures.png`` for the comparison ``doc`` (atomically)."""
    from matplotlib.figure import Figure

    from mwip.io import write_atomic

    st = doc["structures"]
    names: list[str] = []
    for s in st.values():
        names += [n for n in s["marginals"] if n not in names]
    fig = Figure(figsize=(3.0 * len(st) + 2.5, 0.28 * len(names) + 1.6), layout="constrained")
    axes = fig.subplots(1, len(st), sharey=True, squeeze=False)[0]
    for ax, (sname, s) in zip(axes, st.items(), strict=True):
        ax.axvspan(0, WALL, color="0.92")
        ax.axvspan(1 - WALL, 1, color="0.92")
        for i, n in enumerate(names):
            m = s["marginals"].get(n)
            if m is None:
                continue
            q05, q50, q95 = (_unit(m[k], m) for k in ("q05", "q50", "q95"))
            colour = "tab:red" if m["wall"] else "tab:blue"
            ax.plot([q05, q95], [i, i], color=colour, lw=3, solid_capstyle="butt")
            ax.plot([q50], [i], "|", color="k", ms=8)
        status = ("rejected: " + f"{s['most_facts_together']} of "
                  f"{len(s['facts_met_share'])} facts at most" if s["rejected"]
                  else f"{s['found']:,} twins meet every fact")  # fmt: skip
        ax.set_title(f"{sname} ({s['conditioned_draws']:,} twins)\n{status}", fontsize=8)
        ax.set_xlim(0, 1)
        ax.set_xticks([0, 0.5, 1])
        ax.tick_params(labelsize=7)
        ax.set_xlabel("prior range (unit coordinates)", fontsize=7)
    axes[0].set_yticks(range(len(names)), names, fontsize=7)
    axes[0].invert_yaxis()
    fig.suptitle("The twins found meeting each structure's largest consistent subset: 5-95 % "
                 "and median per unknown (red: piled at a prior wall, grey bands)",
                 fontsize=9)  # fmt: skip
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=80,
                                              metadata={"Software": None}))  # fmt: skip
