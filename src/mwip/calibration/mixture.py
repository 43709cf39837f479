"""Stage 4 of the book calibration: independent draws from a box-kernel mixture, pooled.

Why: stage 3's random-walk chains did not converge (``mwip/calibration/chains.py``; the set of
twins meeting the facts is fragmented at fine scales, so local moves wait on isolated
points). Independent draws do not care whether the set is connected: they only need to land
in it often enough. Stage 4 draws ``draws`` twins from a mixture fitted to the twins already
known to meet the conditioned facts (the "seed set": every twin stages 1-3 evaluated that
meets them) and pools them with stages 1-2 by the balance heuristic of multiple importance
sampling (Veach & Guibas 1995; adaptive importance sampling with a proposal fitted to earlier
draws, Cornuet et al. 2012, whose deterministic-mixture weights these are):

    q(x) = sum_k pi_k 1[x in B_k] / V_k,
    B_k = prod_j [max(c_kj - h_kj, lo_j), min(c_kj + h_kj, hi_j)],   V_k = |B_k|,

each component uniform on a box ``B_k`` around a seed twin ``c_k`` with half-widths ``h_k``
(``factor`` times the seed set's standard deviation per unknown), clipped to the prior box
``[lo, hi]``. Unknowns the prior fixes (``lo = hi``) are not part of the measure. With the
uniform prior ``p = 1 / V_prior`` and ``n_s`` draws from each stage's density ``q_s``
(the prior itself, stage 2's box, this mixture), a pooled draw ``x`` weighs

    w(x) = p(x) / (sum_s n_s q_s(x) / N),     N = sum_s n_s,

and the weighted pool estimates expectations under the prior without bias, whatever the
mixture (a proposal that depends on earlier draws is fixed before its own draws are taken).
The weights are bounded (``w <= N / n_prior``: the prior draws are the defensive component,
Hesterberg 1995); a region of the posterior the seed set missed is represented by the prior
and box draws alone, with their (large) weights, so the effective size tells when it matters.

Draw ``s`` takes its numbers from ``(seed, s)`` alone (one integer for the component, then the
uniforms), so the sample is deterministic for a seed and independent of blocks and jobs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["EnvelopePlan", "KernelMixture", "MixturePlan", "balance_weights", "prior_density"]

F64 = NDArray[np.float64]


def _draws_and_seed(section: str, draws: object, seed: object) -> None:
    """A ``ValueError`` naming ``section.draws`` / ``section.seed`` when out of range."""
    if isinstance(draws, bool) or not isinstance(draws, int) or not 0 <= draws <= 1_000_000:
        raise ValueError(f"{section}.draws must be an integer in [0, 1000000], got {draws!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"{section}.seed must be an integer >= 0, got {seed!r}")


@dataclass(frozen=True)
class MixturePlan:
    """Stage 4 as declared: ``draws`` twins, numbers from ``seed``, one equal-share kernel
    family per entry of ``factors`` (half-widths ``factor`` x the seed set's standard
    deviation per unknown), stored in blocks of ``block``; the posterior counts as precise
    when its Kish effective size is at least ``effective``."""

    draws: int
    seed: int
    factors: tuple[float, ...]
    effective: float = 100.0

    def __post_init__(self) -> None:
        _draws_and_seed("mixture", self.draws, self.seed)
        if not self.factors or not all(0.0 < float(f) <= 10.0 for f in self.factors):
            raise ValueError(f"mixture.factors must be a non-empty list of numbers in (0, 10], "
                             f"got {list(self.factors)!r}")  # fmt: skip
        if not (1.0 <= float(self.effective) <= 1e9):
            raise ValueError(f"mixture.effective must be in [1, 1e9], got {self.effective!r}")


@dataclass(frozen=True)
class EnvelopePlan:
    """Stage 5 as declared (revision 4): ``draws`` twins uniform on the envelope (the
    bounding box of every twin stages 1-4 found meeting the facts), numbers from ``seed``;
    with ``max_draws`` (revision 5) it goes on block by block until the pooled posterior's
    effective size reaches ``effective`` or ``max_draws`` are drawn."""

    draws: int
    seed: int
    max_draws: int | None = None
    effective: float | None = None

    def __post_init__(self) -> None:
        _draws_and_seed("envelope", self.draws, self.seed)
        if self.max_draws is not None:
            m = self.max_draws
            if isinstance(m, bool) or not isinstance(m, int) or not (
                    self.draws <= m <= 10_000_000):
                raise ValueError(f"envelope_extension.max_draws must be an integer in "
                                 f"[{self.draws}, 10000000], got {m!r}")  # fmt: skip
            if self.effective is None or not float(self.effective) >= 1.0:
                raise ValueError("envelope_extension needs the effective size to stop at "
                                 f"(>= 1), got {self.effective!r}")  # fmt: skip


def prior_density(bounds: F64) -> float:
    """``p = 1 / V_prior`` of the uniform prior on ``bounds`` (D, 2), over the free unknowns."""
    w = bounds[:, 1] - bounds[:, 0]
    return float(1.0 / np.prod(w[w > 0]))


@dataclass(frozen=True)
class KernelMixture:
    """The mixture of the module docstring: ``lo`` / ``hi`` (M, D) each component's clipped
    box, ``pi`` (M,) its probability; ``free`` (D,) the unknowns the measure runs over."""

    lo: F64
    hi: F64
    pi: F64
    free: NDArray[np.bool_]

    @classmethod
    def fit(cls, seeds: F64, bounds: F64, factors: Sequence[float],
            sd: F64 | None = None) -> KernelMixture:  # fmt: skip
        """One family per ``factor``, equal shares: a component per seed twin (``seeds``
        (M, D) inside ``bounds`` (D, 2)), half-widths ``factor`` x ``sd`` (default: the seeds'
        standard deviation) per free unknown, at least 1e-3 of its prior width (so that a box
        exists where every seed agrees)."""
        x = np.atleast_2d(np.asarray(seeds, dtype=float))
        b = np.asarray(bounds, dtype=float)
        if x.shape[0] < 1 or x.shape[1] != b.shape[0]:
            raise ValueError(f"seeds must be (M >= 1, {b.shape[0]}), got {x.shape}")
        if not np.all((x >= b[:, 0] - 1e-12) & (x <= b[:, 1] + 1e-12)):
            raise ValueError("a seed twin lies outside the prior box")
        w = b[:, 1] - b[:, 0]
        free = w > 0
        sd = np.maximum(x.std(axis=0) if sd is None else np.asarray(sd, dtype=float), 1e-3 * w)
        los, his = [], []
        for f in factors:
            h = np.where(free, float(f) * sd, 0.0)
            los.append(np.maximum(x - h, b[:, 0]))
            his.append(np.minimum(x + h, b[:, 1]))
        lo, hi = np.vstack(los), np.vstack(his)
        lo[:, ~free], hi[:, ~free] = b[~free, 0], b[~free, 0]
        m = lo.shape[0]
        return cls(lo=lo, hi=hi, pi=np.full(m, 1.0 / m), free=free)

    @classmethod
    def envelope(cls, points: F64, bounds: F64) -> KernelMixture:
        """One component: the bounding box of ``points`` (M, D) inside ``bounds`` (D, 2)
        (a free unknown on which every point agrees gets 1e-3 of its prior width about
        them, so that the box has a volume)."""
        x = np.atleast_2d(np.asarray(points, dtype=float))
        b = np.asarray(bounds, dtype=float)
        if x.shape[0] < 1 or x.shape[1] != b.shape[0]:
            raise ValueError(f"points must be (M >= 1, {b.shape[0]}), got {x.shape}")
        w = b[:, 1] - b[:, 0]
        free = w > 0
        lo, hi = x.min(axis=0), x.max(axis=0)
        thin = free & (hi - lo < 1e-3 * w)
        mid = 0.5 * (lo + hi)
        lo = np.where(thin, np.maximum(mid - 5e-4 * w, b[:, 0]), lo)
        hi = np.where(thin, np.minimum(mid + 5e-4 * w, b[:, 1]), hi)
        lo[~free], hi[~free] = b[~free, 0], b[~free, 0]
        return cls(lo=lo[None, :], hi=hi[None, :], pi=np.ones(1), free=free)

    @property
    def volumes(self) -> F64:
        """``V_k`` over the free unknowns."""
        return np.prod((self.hi - self.lo)[:, self.free], axis=1)

    def density(self, x: F64, chunk: int = 512) -> F64:
        """``q(x)`` for the rows of ``x`` (N, D) (zero outside every component)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        f = self.free
        lo, hi = self.lo[:, f], self.hi[:, f]
        coef = self.pi / self.volumes
        out = np.zeros(x.shape[0])
        for a in range(0, x.shape[0], chunk):
            xs = x[a:a + chunk, f][:, None, :]
            ins = np.all((xs >= lo[None] - 1e-12) & (xs <= hi[None] + 1e-12), axis=2)
            out[a:a + chunk] = ins @ coef
        return out

    def draw(self, seed: int, index: Sequence[int]) -> F64:
        """Draws ``index`` of the sample ``seed`` (N, D): component ``k ~ pi``, then uniform
        in ``B_k``; draw ``s`` uses the generator of ``(seed, s)`` alone."""
        from mwip.campaign.sampling import sample_rng

        cdf = np.cumsum(self.pi)
        cdf[-1] = 1.0
        out = np.zeros((len(index), self.lo.shape[1]))
        for r, s in enumerate(index):
            g = sample_rng(seed, int(s))
            k = int(np.searchsorted(cdf, g.random(), side="right"))
            k = min(k, len(cdf) - 1)
            out[r] = self.lo[k] + g.random(self.lo.shape[1]) * (self.hi[k] - self.lo[k])
        return out


def balance_weights(p: F64, counts: Sequence[int], densities: Sequence[F64]) -> F64:
    """``w = p N / sum_s n_s q_s`` (module docstring) of pooled draws: ``p`` (N,) the prior
    density at each draw, ``counts`` the draws per stage, ``densities`` each stage's density
    at every pooled draw ((N,) each). Mean weight over the pool estimates 1."""
    n = float(sum(counts))
    mix = sum(float(c) * np.asarray(q, dtype=float) for c, q in zip(counts, densities,
                                                                     strict=True))  # fmt: skip
    return np.asarray(p, dtype=float) * n / np.asarray(mix, dtype=float)
