"""Stage 2 of the book calibration: adaptive ABC population Monte Carlo over the prior.

Why: the consistent set of the book's calibration facts is a thin corner of the 17-dimensional
prior box (a low gear ratio, a small dead-band, little Coulomb and viscous friction, back-EMF
compensation, a fusion constant in a band, all at once), so plain prior draws almost never
land in it (the declared 2,000 draws of stage 1 met 13 of the 27 facts with no draw at all).
Stage 2 concentrates draws where the facts are met, with importance weights that keep the
posterior the declared one: the uniform prior restricted to the twins that meet the facts.
It changes no prior, tolerance, split or rule (``book-evidence.toml``, ``[refine]``).

The algorithm is the adaptive population Monte Carlo ABC of Lenormand, Jabot & Deffuant
(2013, *Comput. Stat.* 28: 2777-2796), in the prior's unit cube ``u = (x - lo) / (hi - lo)``:

1. The population: the ``keep`` draws of stage 1 closest to the evidence (distance
   :func:`distance`), weights 1 (uniform prior, uniform proposal).
2. Each generation proposes ``propose`` new twins from the weighted population with a
   Gaussian kernel per particle, of diagonal covariance the optimal local covariance
   (:func:`local_sigma`; ``local = 0``: ``2 Var_w(u)`` for all, Beaumont et al. 2009),
   truncated to the cube, and weighs each by ``pi(u) / q(u)``, ``q`` the exactly normalised
   truncated mixture :func:`proposal_density` (uniform prior: ``pi = 1``).
3. The old population and the new twins are merged and the ``keep`` closest kept; the
   threshold ``epsilon`` is the largest distance kept. It stops when the fraction of new
   twins within the previous threshold falls below ``min_acceptance``, when ``epsilon`` is 0
   (every kept twin meets every fact), or after ``generations``.

The final population, with its weights, is what :mod:`mwip.calibration.posterior` conditions
(the facts it meets; the largest consistent subset when some facts are met by no twin).

Each generation's random numbers come from ``(seed, generation)`` alone and each twin's runs
are independent of the batch it is in, so the result is deterministic for a seed, whatever
``jobs``; every generation is stored (``OUT/refine/gen-NN.parquet``) and a rerun resumes.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.calibration.evidence import Evidence

__all__ = ["Refine", "distance", "local_sigma", "proposal_density", "propose", "refine"]

#: Offset of the generation index in the random streams (stage 1 uses the draw index).
_STREAM = 1_000_000


@dataclass(frozen=True)
class Refine:
    """The declared settings of stage 2 (``book-evidence.toml``, ``[refine]``)."""

    keep: int = 250
    propose: int = 250
    generations: int = 12
    min_acceptance: float = 0.02
    local: float = 0.0

    def __post_init__(self) -> None:
        for name in ("keep", "propose", "generations"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 100_000:
                raise ValueError(f"refine.{name} must be an integer in [1, 100000], got {v!r}")
        if not 0.0 <= self.local <= 1.0:
            raise ValueError(f"refine.local must be in [0, 1], got {self.local!r}")
        if not 0.0 <= self.min_acceptance < 1.0:
            raise ValueError(
                f"refine.min_acceptance must be in [0, 1), got {self.min_acceptance!r}"
            )


def distance(cols: Mapping[str, NDArray[np.float64]], run_names: Sequence[str],
             durations: Mapping[str, float], ev: Evidence,
             use: frozenset[str] | None = None) -> NDArray[np.float64]:  # fmt: skip
    """Distance of each twin to the calibration evidence, 0 exactly when it meets every fact
    (of ``use``, fact names ``up:<run>`` / ``num:<key>`` as :func:`posterior.facts`; default
    all).

    Per run that fell: ``1 + (1 - t_end / T)`` (a later fall is closer); per calibration
    number: ``max(0, |ln(x / book)| - ln(tol)) / ln(tol)``, and 1 where the run fell. The sum
    over facts; so a twin meeting ``k`` more facts than another is, up to the partial terms,
    ``k`` closer.
    """
    d = np.zeros(len(np.asarray(cols[f"{run_names[0]}.stands"])))
    for r in run_names:
        if use is not None and f"up:{r}" not in use:
            continue
        up = np.asarray(cols[f"{r}.stands"], dtype=float) == 1.0
        t_end = np.nan_to_num(np.asarray(cols[f"{r}.t_end"], dtype=float))
        frac = np.clip(t_end / float(durations[r]), 0.0, 1.0)
        d += np.where(up, 0.0, 2.0 - frac)
    lt = ev.log_tolerance
    for n in ev.numbers:
        if use is not None and f"num:{n.key}" not in use:
            continue
        x = np.asarray(cols[n.key], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.where(x > 0, np.abs(np.log(x / n.book)), np.nan)
        d += np.where(np.isfinite(e), np.maximum(e - lt, 0.0) / lt, 1.0)
    return d


def _phi(z: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.special import ndtr

    return np.asarray(ndtr(z), dtype=float)


def proposal_density(u: NDArray[np.float64], centres: NDArray[np.float64],
                     weights: NDArray[np.float64],
                     sigma: NDArray[np.float64]) -> NDArray[np.float64]:  # fmt: skip
    """Density at ``u`` (M, D) of the mixture ``sum_j w_j N(c_j, diag s_j^2)`` truncated to
    the unit cube and normalised there (``weights`` sum to 1; ``sigma`` (D,) for one kernel
    width, or (J, D) for one per centre):
    ``q(u) = sum_j w_j N(u; c_j, s_j) / sum_j w_j P_j``, ``P_j = prod_d [Phi((1 - c_jd) /
    s_jd) - Phi(-c_jd / s_jd)]`` the mass of kernel ``j`` inside the cube."""
    s = np.broadcast_to(sigma, centres.shape)
    out = np.empty(len(u))
    for a in range(0, len(u), 256):  # (M, J, D) in slices: memory
        z = (u[a:a + 256, None, :] - centres[None, :, :]) / s[None]
        log_k = -0.5 * np.sum(z * z, axis=2) - np.sum(np.log(s * np.sqrt(2 * np.pi)), axis=1)
        out[a:a + 256] = np.exp(log_k) @ weights
    mass = np.prod(_phi((1.0 - centres) / s) - _phi(-centres / s), axis=1)  # (J,)
    return out / float(weights @ mass)


def propose(rng: np.random.Generator, centres: NDArray[np.float64],
            weights: NDArray[np.float64], sigma: NDArray[np.float64],
            n: int) -> NDArray[np.float64]:  # fmt: skip
    """``n`` draws from the truncated mixture of :func:`proposal_density`: a parent by weight
    and a Gaussian step, the pair drawn again (parent too) while the step leaves the cube:
    rejection sampling of the mixture, whose density is then the mixture's restricted to the
    cube and normalised by its total mass there (redrawing the step alone would normalise each
    kernel by its own mass instead)."""
    s = np.broadcast_to(sigma, centres.shape)
    out = np.empty((n, centres.shape[1]))
    for i in range(n):
        while True:
            j = rng.choice(len(centres), p=weights)
            x = centres[j] + s[j] * rng.standard_normal(centres.shape[1])
            if np.all((x >= 0.0) & (x <= 1.0)):
                out[i] = x
                break
    return out


def local_sigma(u: NDArray[np.float64], w: NDArray[np.float64], d: NDArray[np.float64],
                fraction: float) -> NDArray[np.float64]:  # fmt: skip
    """Kernel widths, one per particle and dimension (J, D): the diagonal of the optimal local
    covariance (OLCM, Filippi et al. 2013, *Stat. Appl. Genet. Mol. Biol.* 12: 87-107),
    ``s_jd^2 = sum_k w_k (u_kd - u_jd)^2 / sum_k w_k`` over the particles ``k`` closest to the
    evidence (the ``fraction`` of the population with the smallest distance: those the next
    threshold would keep), so each particle steps toward where the better ones are; ``fraction
    = 0`` gives Beaumont et al.'s (2009) one width ``2 Var_w(u)`` for all."""
    if fraction <= 0.0:
        mean = w @ u
        return np.broadcast_to(np.sqrt(np.maximum(2.0 * (w @ (u - mean) ** 2), 1e-8)),
                               u.shape).copy()  # fmt: skip
    k = max(2, int(np.ceil(fraction * len(u))))
    best = np.argsort(d, kind="stable")[:k]
    wb = w[best] / w[best].sum()
    diff2 = (u[best][None, :, :] - u[:, None, :]) ** 2  # (J, k, D)
    return np.sqrt(np.maximum(np.einsum("k,jkd->jd", wb, diff2), 1e-6))


def _to_parquet(frame: Any, fh: Any) -> None:
    frame.to_parquet(fh, index=False)


def _select(d: NDArray[np.float64], keep: int) -> NDArray[np.intp]:
    """Indices of the ``keep`` smallest distances (ties: the earlier row)."""
    return np.argsort(d, kind="stable")[:keep]


def refine(
    table0: Any,
    ev: Evidence,
    settings: Refine,
    *,
    names: Sequence[str],
    bounds: NDArray[np.float64],
    run_names: Sequence[str],
    durations: Mapping[str, float],
    evaluate: Callable[[dict[str, NDArray[np.float64]]], dict[str, NDArray[np.float64]]],
    seed: int,
    use: frozenset[str] | None = None,
    phase: str = "all",
    stream: int = 0,
    store: Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[Any, list[dict[str, Any]], Any]:
    """Run one phase of stage 2 from ``table0`` (every twin evaluated so far: columns
    ``param.<name>``, the runs' metrics and ``weight``, the importance weight of the proposal
    it came from); ``evaluate(values)`` runs every Chapter 6 run on a batch of twins and
    returns its columns; ``use`` the facts the distance counts (default all); ``stream``
    offsets the generations' random streams (one per phase). Returns the final population (a
    DataFrame with ``weight``, ``distance`` and ``generation`` columns), one record per
    generation (threshold, acceptance, twins meeting every fact) and every twin evaluated."""
    import pandas as pd

    from mwip.campaign.sampling import sample_rng
    from mwip.io import write_atomic

    lo, hi = bounds[:, 0], bounds[:, 1]
    span = np.where(hi > lo, hi - lo, 1.0)
    pcols = [f"param.{n}" for n in names]

    def unit(tab: Any) -> NDArray[np.float64]:
        return (tab[pcols].to_numpy(dtype=float) - lo) / span

    t0 = table0.copy()
    t0["distance"] = distance({c: t0[c].to_numpy() for c in t0.columns if c != "evidence"},
                              run_names, durations, ev, use)  # fmt: skip
    if "weight" not in t0:
        t0["weight"] = 1.0
    if "generation" not in t0:
        t0["generation"] = 0
    pool = [t0]
    pop = t0.iloc[_select(t0["distance"].to_numpy(), settings.keep)].reset_index(drop=True)
    eps = float(pop["distance"].max())
    history: list[dict[str, Any]] = [{
        "phase": phase, "generation": 0, "evaluated": len(t0), "epsilon": eps,
        "acceptance": None, "at_zero": int((pop["distance"] == 0).sum())}]  # fmt: skip
    for g in range(1, settings.generations + 1):
        if eps <= 0.0:
            break
        u_pop = unit(pop)
        w = pop["weight"].to_numpy(dtype=float)
        w = w / w.sum()
        sigma = local_sigma(u_pop, w, pop["distance"].to_numpy(), settings.local)
        path = store / f"{phase}-gen-{g:02d}.parquet" if store is not None else None
        if path is not None and path.exists():
            new = pd.read_parquet(path)
        else:
            rng = sample_rng(seed, _STREAM + stream + g)
            u_new = propose(rng, u_pop, w, sigma, settings.propose)
            x_new = lo + u_new * span
            values = {n: x_new[:, j].copy() for j, n in enumerate(names)}
            cols = evaluate(values)
            new = pd.DataFrame({"evidence": "book",
                                "sample": np.arange(settings.propose)
                                + (stream + g) * _STREAM,
                                **{f"param.{n}": v for n, v in values.items()}, **cols})
            new["distance"] = distance(cols, run_names, durations, ev, use)
            new["weight"] = 1.0 / proposal_density(u_new, u_pop, w, sigma)
            new["generation"] = g
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(path, functools.partial(_to_parquet, new))
        pool.append(new)
        acc = float(np.mean(new["distance"].to_numpy() <= eps))
        merged = pd.concat([pop, new], ignore_index=True)
        pop = merged.iloc[_select(merged["distance"].to_numpy(), settings.keep)]
        pop = pop.reset_index(drop=True)
        eps = float(pop["distance"].max())
        history.append({"phase": phase, "generation": g, "evaluated": len(new), "epsilon": eps,
                        "acceptance": acc, "at_zero": int((pop["distance"] == 0).sum())})
        if progress is not None:
            progress(f"refine ({phase}): generation {g}: threshold {eps:.3g}, {acc:.0%} of "
                     f"the new twins within the previous one, {history[-1]['at_zero']} meet "
                     "every fact")
        if acc < settings.min_acceptance:
            break
    return pop, history, pd.concat(pool, ignore_index=True)
