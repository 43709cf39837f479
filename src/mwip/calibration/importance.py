"""Stage D of the book calibration's revision 9: a structure's evidence by importance
sampling (``book-structures.toml``, ``[revision_9]``).

Revision 8's directed search found twins meeting every calibration fact where no prior draw
did, so ``Z = P_prior(every fact met)`` read on the prior draws is 0 with only an upper
bound. Stage D weighs that thin set. In the prior's unit coordinates ``u in [0, 1]^D``
(prior density 1 on the free unknowns), from the proposal

    q(u) = a + (1 - a) K(u),

``a`` the *defensive* share (the prior itself, Hesterberg 1995) and ``K`` the box-kernel
mixture of stage B's rule (:class:`mwip.calibration.mixture.KernelMixture`: one equal-share
family per ``factor``, a box of half-widths ``factor`` x the seeds' standard deviation around
each seed) around the twins of stages A-C meeting every fact. ``q`` depends on those earlier
stages only, never on its own draws, so the importance weights

    w(u) = 1 / q(u) <= 1 / a

are exact and ``mean_i w_i f(u_i)`` estimates the prior expectation of ``f`` without bias:
``Z ~ mean_i w_i 1[u_i meets every fact]``, the posterior (the prior restricted to the facts)
is the draws meeting them weighted by ``w``. A part of the set the seeds missed is reached by
the defensive share alone, with weight up to ``1 / a``: the estimate stays unbiased, and the
interval (:mod:`mwip.calibration.compare`, delta method) widens when such a draw lands.

Draw ``s`` (index ``STAGE_D + s``) takes its numbers from the generator of ``(seed, STAGE_D +
s)`` alone: one uniform picks the prior (below ``a``) or a box (by its share), then the
coordinates; so the sample does not depend on blocks or jobs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.calibration.mixture import KernelMixture

__all__ = ["ImportancePlan", "DefensiveProposal", "importance_search", "STAGE_D"]

F64 = NDArray[np.float64]

#: Stage D's draw indices start here (A at 0, B at 1,000,000, C at 2,000,000).
STAGE_D = 3_000_000


@dataclass(frozen=True)
class ImportancePlan:
    """The declared stage D (``[revision_9]``): ``draws`` per structure, the ``defensive``
    share of the prior, the kernel ``factors``, the ``seed``."""

    draws: int
    defensive: float
    factors: tuple[float, ...]
    seed: int

    def __post_init__(self) -> None:
        d = self.draws
        if isinstance(d, bool) or not isinstance(d, int) or not 0 <= d <= 1_000_000:
            raise ValueError(f"revision_9.draws must be an integer in [0, 1000000], got {d!r}")
        if not 0.0 < float(self.defensive) < 1.0:
            raise ValueError(f"revision_9.defensive must be a number in (0, 1), got "
                             f"{self.defensive!r}")  # fmt: skip
        if not self.factors or not all(0.0 < float(f) <= 10.0 for f in self.factors):
            raise ValueError(f"revision_9.factors must be a non-empty list of numbers in "
                             f"(0, 10], got {list(self.factors)!r}")  # fmt: skip
        s = self.seed
        if isinstance(s, bool) or not isinstance(s, int) or s < 0:
            raise ValueError(f"revision_9.seed must be an integer >= 0, got {s!r}")


@dataclass(frozen=True)
class DefensiveProposal:
    """``q = a + (1 - a) K`` of the module docstring over the unit box of the ``free``
    unknowns (a fixed unknown's coordinate is 0)."""

    kernel: KernelMixture
    defensive: float

    @classmethod
    def fit(cls, seeds: F64, free: NDArray[np.bool_], factors: Sequence[float],
            defensive: float) -> DefensiveProposal:  # fmt: skip
        """Around the unit coordinates ``seeds`` (M, D) of the twins meeting every fact."""
        unit = np.column_stack([np.zeros(free.size), free.astype(float)])
        return cls(KernelMixture.fit(seeds, unit, factors), float(defensive))

    def density(self, u: F64) -> F64:
        """``q(u)`` for the rows of ``u`` (N, D)."""
        return self.defensive + (1.0 - self.defensive) * self.kernel.density(u)

    def weights(self, u: F64) -> F64:
        """``w = 1 / q(u)``: the prior's density (1) over the proposal's."""
        return 1.0 / self.density(u)

    def draw(self, seed: int, index: Sequence[int]) -> F64:
        """Draws ``index`` (N, D) of the sample ``seed`` (module docstring)."""
        from mwip.campaign.sampling import sample_rng

        k = self.kernel
        free = k.free
        cdf = np.cumsum(k.pi)
        cdf[-1] = 1.0
        out = np.zeros((len(index), k.lo.shape[1]))
        for r, s in enumerate(index):
            g = sample_rng(seed, int(s))
            pick = g.random()
            if pick < self.defensive:
                out[r] = g.random(free.size) * free
                continue
            c = (pick - self.defensive) / (1.0 - self.defensive)  # uniform on [0, 1)
            j = min(int(np.searchsorted(cdf, c, side="right")), cdf.size - 1)
            out[r] = k.lo[j] + g.random(free.size) * (k.hi[j] - k.lo[j])
        return out


def importance_search(structure: Any, plan: ImportancePlan, store: Path, rows: Any,
                      run: Callable[[F64], dict[str, Any]],
                      meets: Callable[[Any], NDArray[np.bool_]], *, block: int,
                      note: Callable[[str], None] | None = None) -> Any:  # fmt: skip
    """Stage D of ``structure`` after its stage A-C ``rows`` (``meets`` maps rows to whether
    each meets every fact): ``plan.draws`` twins of the proposal fitted to the rows meeting
    every fact, with a ``weight`` column (``1 / q``) and ``stage`` ``"D"``, stored in blocks
    (a rerun resumes). No row where no earlier twin meets every fact, or ``draws`` is 0."""
    from mwip.calibration.comparison import _blocks

    names = structure.prior.names
    cols = [f"u.{n}" for n in names]
    hit = meets(rows)
    if plan.draws == 0 or not np.any(hit):
        return rows.iloc[:0]
    free = structure.prior.bounds[:, 1] > structure.prior.bounds[:, 0]
    q = DefensiveProposal.fit(rows[cols].to_numpy(dtype=float)[hit], free, plan.factors,
                              plan.defensive)  # fmt: skip
    idx = STAGE_D + np.arange(plan.draws, dtype=np.int64)
    u = q.draw(plan.seed, idx.tolist())
    df = _blocks(names, structure.name, "D", u, idx, store, block, run, note)
    df["stage"] = "D"
    df["weight"] = q.weights(df[cols].to_numpy(dtype=float))
    return df
