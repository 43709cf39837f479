"""Stage 2 of the book calibration: defensive importance sampling with a declared box.

Why: the twins that meet the book's calibration facts lie in a thin corner of the 17-dimensional
prior box (a low gear ratio, back-EMF compensation, a small dead-band, little Coulomb and
viscous friction, all at once): uniform prior draws almost never land there (the declared
2,000 draws of stage 1 met 13 of the 27 facts with no draw at all). Stage 2 draws ``draws``
more twins uniformly from a declared sub-box of the prior (``book-evidence.toml``,
``[proposal]``: narrower ranges for some unknowns, the prior's for the rest) and pools them
with the prior draws under the balance heuristic of multiple importance sampling (Veach &
Guibas 1995; "defensive" mixture, Hesterberg 1995):

    w(x) = p(x) / ((n_1 p(x) + n_2 q(x)) / (n_1 + n_2)),    p = 1 / V_prior,  q = 1_box / V_box,

so ``w = (n_1 + n_2) / (n_1 + n_2 [x in box] / f)``, ``f = V_box / V_prior``. The weighted
pool estimates expectations under the prior exactly (unbiased), whatever the box: the box
changes how precisely the corner is known, never the posterior (the prior, the split, the
tolerance and the rules stay as declared). Twins outside the box are represented by the prior
draws alone.

Draw ``s`` takes its uniform numbers from ``(seed, s)`` alone (like stage 1), so the result is
deterministic for a seed and independent of blocks and jobs; each block is stored
(``OUT/proposal/block-NNN.parquet``) and a rerun resumes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoxProposal", "inside", "mis_weights", "sample_blocks", "sample_box"]


@dataclass(frozen=True)
class BoxProposal:
    """``draws`` twins uniform on the prior box narrowed to ``box`` (name -> (low, high))."""

    draws: int
    seed: int
    box: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if isinstance(self.draws, bool) or not isinstance(self.draws, int) or not (
                0 <= self.draws <= 1_000_000):
            raise ValueError(f"proposal.draws must be an integer in [0, 1000000], "
                             f"got {self.draws!r}")  # fmt: skip
        for name, (lo, hi) in self.box.items():
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"proposal.box.{name}: low < high, both finite, got "
                                 f"[{lo!r}, {hi!r}]")  # fmt: skip

    def ranges(self, names: Sequence[str], bounds: NDArray[np.float64]) -> NDArray[np.float64]:
        """The box as (D, 2) ranges over the prior's unknowns ``names`` (``bounds`` (D, 2));
        a ``ValueError`` names an entry outside the prior or not one of its unknowns."""
        out = np.array(bounds, dtype=float, copy=True)
        for name, (lo, hi) in self.box.items():
            if name not in names:
                raise ValueError(f"proposal.box.{name}: not an unknown of the twin's prior")
            j = list(names).index(name)
            if lo < bounds[j, 0] - 1e-12 or hi > bounds[j, 1] + 1e-12:
                raise ValueError(f"proposal.box.{name}: [{lo:g}, {hi:g}] is not inside the "
                                 f"prior's [{bounds[j, 0]:g}, {bounds[j, 1]:g}]")  # fmt: skip
            out[j] = (lo, hi)
        return out

    def fraction(self, names: Sequence[str], bounds: NDArray[np.float64]) -> float:
        """``f = V_box / V_prior`` (unknowns fixed by the prior, ``low = high``, count 1)."""
        r = self.ranges(names, bounds)
        wp = bounds[:, 1] - bounds[:, 0]
        wb = r[:, 1] - r[:, 0]
        return float(np.prod(np.where(wp > 0, wb / np.where(wp > 0, wp, 1.0), 1.0)))


def inside(x: NDArray[np.float64], ranges: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Rows of ``x`` (N, D) inside the box ``ranges`` (D, 2)."""
    return np.all((x >= ranges[:, 0] - 1e-12) & (x <= ranges[:, 1] + 1e-12), axis=1)


def mis_weights(in_box: NDArray[np.bool_], n_prior: int, n_box: int, fraction: float
                ) -> NDArray[np.float64]:  # fmt: skip
    """The balance-heuristic weights of the pooled draws (module docstring): ``in_box`` per
    pooled draw (prior draws and box draws alike); mean weight over the pool estimates 1."""
    n = n_prior + n_box
    rate = n_prior + n_box * np.asarray(in_box, dtype=float) / fraction
    return n / rate


def sample_box(
    proposal: BoxProposal,
    names: Sequence[str],
    bounds: NDArray[np.float64],
    evaluate: Callable[[dict[str, NDArray[np.float64]]], dict[str, NDArray[np.float64]]],
    *,
    block: int = 250,
    store: Path | None = None,
    note: Callable[[str], None] | None = None,
) -> Any:
    """Evaluate the proposal's draws in blocks (resumable in ``store``); returns a DataFrame
    with ``sample`` (offset 10^9: never a stage-1 index), ``param.<name>`` and the runs'
    columns."""
    from mwip.campaign.sampling import sample_rng

    r = proposal.ranges(names, bounds)

    def draw(idx: Sequence[int]) -> NDArray[np.float64]:
        u = np.array([sample_rng(proposal.seed, int(i)).random(len(names)) for i in idx])
        return np.asarray(r[:, 0] + u * (r[:, 1] - r[:, 0]), dtype=float)

    return sample_blocks(draw, proposal.draws, names, evaluate, block=block, store=store,
                         note=note, offset=10**9, label="proposal")  # fmt: skip


def sample_blocks(
    draw: Callable[[Sequence[int]], NDArray[np.float64]],
    draws: int,
    names: Sequence[str],
    evaluate: Callable[[dict[str, NDArray[np.float64]]], dict[str, NDArray[np.float64]]],
    *,
    block: int = 250,
    store: Path | None = None,
    note: Callable[[str], None] | None = None,
    offset: int = 10**9,
    label: str = "proposal",
    first: int = 0,
) -> Any:
    """Draws ``0 .. draws - 1`` of an independent sampler (``draw(indices)`` -> (n, D) over
    ``names``), evaluated in blocks of ``block``, each stored as ``store/block-NNN.parquet``
    and replayed by a rerun; a DataFrame with ``sample`` (``offset`` + the draw's index),
    ``param.<name>`` and the runs' columns; ``first``: start at that block (the earlier ones
    are the caller's)."""
    import pandas as pd

    from mwip.calibration.clock import StepClock
    from mwip.io import write_parquet_atomic

    parts = []
    n_blocks = -(-draws // block) if draws else 0
    clock = StepClock(n_blocks)
    for b in range(first, n_blocks):
        idx = range(b * block, min((b + 1) * block, draws))
        path = store / f"block-{b:03d}.parquet" if store is not None else None
        if path is not None and path.exists():
            parts.append(pd.read_parquet(path))
        else:
            x = draw(idx)
            values = {n: x[:, j].copy() for j, n in enumerate(names)}
            cols = evaluate(values)
            df = pd.DataFrame({"evidence": "book", "sample": np.asarray(idx) + offset,
                               **{f"param.{n}": v for n, v in values.items()}, **cols})  # fmt: skip
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_parquet_atomic(path, df)
            parts.append(df)
            clock.ran(b)
        if note is not None:
            note(f"{label}: block {b + 1}/{n_blocks} done ({len(idx)} twins){clock.left(b)}")
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
