"""Stage C of the book calibration's revision 8: a directed search for a twin meeting every
calibration fact (``book-structures.toml``, ``[revision_8]``).

Revision 7 reads "structure rejected" as "no twin of stages A and B meets every fact": an
existence claim resting on a search. Stage C searches harder where that claim would be made,
by a deterministic evolution strategy in the prior's unit coordinates ``u in [0, 1]^D``:

- the **violation** of a twin, ``v = sum_up 1[the run fell] + sum_num max(0, |ln(x / book)| /
  ln(tolerance) - 1)`` (a number of a fallen run counts 1): ``v = 0`` exactly when it meets
  every fact;
- generation ``g`` (``0 .. generations - 1``): the ``parents`` twins of smallest violation
  among every twin evaluated so far (stages A, B and earlier generations; ties by draw
  index); ``per_generation`` children, child ``i`` of parent ``i mod parents``, ``u' = u +
  sigma * z`` with ``z ~ N(0, 1)`` from the generator of ``(seed, g)``, reflected into
  ``[0, 1]`` on free unknowns (a fixed one stays 0); ``sigma`` per unknown is the parents'
  standard deviation, at least ``min_step``;
- draw indices ``STAGE_C + g * 100_000 + i``.

It is a search: it finds twins, it does not weigh them; ``Z`` stays stage A's
(:mod:`mwip.calibration.comparison`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["DirectedPlan", "violation", "directed_search", "STAGE_C"]

#: Stage C's draw indices start here (stage A's at 0, stage B's at 1,000,000).
STAGE_C = 2_000_000


@dataclass(frozen=True)
class DirectedPlan:
    """The declared stage C (``[revision_8]``)."""

    generations: int
    per_generation: int
    parents: int
    min_step: float
    seed: int


def violation(f: Any, log_tolerance: float) -> NDArray[np.float64]:
    """``v`` of the module docstring per row of the fact table ``f``
    (:class:`mwip.calibration.posterior.Facts`: standing facts ``up:*``, then numbers)."""
    up = np.array([n.startswith("up:") for n in f.names])
    v = np.sum(~f.S[:, up], axis=1).astype(float)
    if f.log_err.shape[1]:
        e = np.abs(f.log_err) / log_tolerance - 1.0
        v += np.sum(np.where(np.isfinite(e), np.maximum(e, 0.0), 1.0), axis=1)
    return v


def _children(parents: NDArray[np.float64], free: NDArray[np.bool_], n: int, plan: DirectedPlan,
              g: int) -> NDArray[np.float64]:  # fmt: skip
    from mwip.campaign.sampling import sample_rng

    rng = sample_rng(plan.seed, g)
    sigma = np.maximum(parents.std(axis=0), plan.min_step) * free
    base = parents[np.arange(n) % len(parents)]
    u = base + sigma * rng.standard_normal(base.shape)
    u = np.abs(u)  # reflect at 0 ...
    u = np.where(u > 1.0, 2.0 - u, u)  # ... and at 1 (a step above 1 stays inside)
    return np.clip(u, 0.0, 1.0) * free


def directed_search(structure: Any, plan: DirectedPlan, store: Path, rows: Any,
                    run: Callable[[NDArray[np.float64]], dict[str, Any]],
                    score: Callable[[Any], NDArray[np.float64]], *, block: int,
                    note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Stage C (module docstring) of ``structure`` after its stage A and B ``rows``:
    ``score`` maps rows to their violation. The generations' rows with a ``stage`` column
    ``"C"`` (stored per generation: a rerun resumes)."""
    import pandas as pd

    from mwip.calibration.comparison import _blocks

    names = structure.prior.names
    free = structure.prior.bounds[:, 1] > structure.prior.bounds[:, 0]
    cols = [f"u.{n}" for n in names]
    seen = rows
    out = []
    for g in range(plan.generations):
        v = score(seen)
        order = np.lexsort((seen["sample"].to_numpy(), v))[: plan.parents]
        parents = seen[cols].to_numpy(dtype=float)[order]
        u = _children(parents, free, plan.per_generation, plan, g)
        idx = STAGE_C + g * 100_000 + np.arange(plan.per_generation, dtype=np.int64)
        df = _blocks(names, structure.name, f"C{g:02d}", u, idx, store, block, run, note)
        df["stage"] = "C"
        out.append(df)
        seen = pd.concat([seen, df], ignore_index=True)
    return pd.concat(out, ignore_index=True) if out else rows.iloc[:0]
