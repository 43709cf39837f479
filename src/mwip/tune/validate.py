"""Validation: the tuned settings against the book's, on the tuning robots and on robots and
noise seeds the tuner never saw (the objective's ``[validation]``: another seed).

For each robot set and each of the two settings: the success rate ``k / n`` with its Wilson
95 % interval (:func:`mwip.schema.robustness.wilson`); each term's mean over the successful
robots with a 95 % percentile-bootstrap interval (2000 resamples of the successful robots,
seeded, so the numbers are reproducible); the scalar cost. And the paired difference of the
success rates (tuned - book, the same robots and noise: common random numbers) with its 95 %
bootstrap interval over robots.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.schema.robustness import wilson
from mwip.tune.evaluate import RobotSet, evaluate
from mwip.tune.objective import Objective, scalar_cost, successes

__all__ = ["validate", "bootstrap_mean", "BOOTSTRAP"]

#: Bootstrap resamples.
BOOTSTRAP = 2000


def bootstrap_mean(x: NDArray[np.float64], seed: int = 0,
                   n: int = BOOTSTRAP) -> tuple[float, float]:  # fmt: skip
    """The 95 % percentile-bootstrap interval of the mean of ``x`` (``nan`` if empty)."""
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, x.size, size=(n, x.size))].mean(axis=1)
    lo, hi = np.quantile(means, [0.025, 0.975])
    return float(lo), float(hi)


def _summary(obj: Objective, met: Mapping[str, NDArray], drive: str) -> dict[str, Any]:
    ok = successes(obj, dict(met), drive)
    k, n = int(ok.sum()), int(ok.size)
    lo, hi = wilson(k, n)
    out: dict[str, Any] = {"successes": k, "robots": n, "success_rate": k / n,
                           "success_interval": [lo, hi],
                           "cost": scalar_cost(obj, dict(met), drive), "terms": {}}  # fmt: skip
    for t in obj.terms:
        x = np.asarray(met[t.metric], dtype=float)[ok]
        mean = float(x.mean()) if x.size else math.nan
        out["terms"][t.metric] = {"mean": mean, "interval": list(bootstrap_mean(x))}
    return out


def validate(
    name: str,
    tuned: Mapping[str, Any],
    obj: Objective,
    sets: Mapping[str, RobotSet],
) -> dict[str, Any]:
    """``{set: {"book": summary, "tuned": summary, "difference": ...}}`` (module docstring)."""
    out: dict[str, Any] = {}
    for label, robots in sets.items():
        drive = robots.campaign.drive
        book, mine = evaluate(name, [{}, dict(tuned)], robots)
        entry: dict[str, Any] = {"robots": robots.samples, "seed": robots.campaign.seed,
                                 "book": _summary(obj, book, drive),
                                 "tuned": _summary(obj, mine, drive)}  # fmt: skip
        a = successes(obj, book, drive).astype(float)
        b = successes(obj, mine, drive).astype(float)
        entry["difference"] = {"success_rate": float((b - a).mean()),
                               "interval": list(bootstrap_mean(b - a, seed=1))}  # fmt: skip
        out[label] = entry
    return out
