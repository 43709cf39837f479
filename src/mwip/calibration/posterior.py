"""From prior draws to the posterior: facts, acceptance, conflicts, marginals, the MAP twin.

A *fact* is one calibration statement about one draw: ``up:<run>`` (the run stood for its
whole duration) for every Chapter 6 run, and ``num:<key>`` (the number is within the declared
factor of the book's, ``|ln(x / book)| <= ln(tolerance)``). ``S[i, j]`` says whether draw
``i`` satisfies fact ``j``.

- Consistent draws satisfy every fact. If none does, the facts conflict: the *smallest
  conflicting sets* are the minimal sets of facts no draw satisfies together (searched up to
  three facts, exhaustively), and the posterior is conditioned on the *largest consistent
  subset*: the largest set of facts some draw satisfies (ties: the one more draws satisfy,
  then the first in fact order), named in the report.
- The most probable member maximises the ABC kernel ``exp(-1/2 sum_k (ln(x_k/b_k)/s)^2)``,
  ``s = ln(tolerance) / 2``, over the consistent draws (uniform prior: the posterior density
  is the kernel) - the new default twin.
- Marginals: each unknown's posterior quantiles (5, 50, 95 %) against its prior range; it is
  *identified* when the posterior 90 % interval is narrower than the declared fraction of the
  prior's 90 % interval (uniform prior: 0.9 of the range).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.calibration.evidence import Evidence

__all__ = ["Facts", "facts", "Posterior", "condition", "consistent_subset",
           "smallest_conflicts", "weighted_quantile"]


@dataclass(frozen=True)
class Facts:
    """``names`` (J,) and the (N, J) boolean table ``S``; ``log_err`` (N, K): ``ln(x/book)``
    of each calibration number (``nan`` where the run fell)."""

    names: tuple[str, ...]
    S: NDArray[np.bool_]
    log_err: NDArray[np.float64]


def weighted_quantile(x: NDArray[np.float64], w: NDArray[np.float64],
                      q: Sequence[float]) -> NDArray[np.float64]:  # fmt: skip
    """Quantiles of ``x`` under weights ``w``: the weighted empirical CDF with the midpoint
    rule, ``F(x_(i)) = (sum_{j<=i} w_j - w_i / 2) / sum w``, interpolated linearly (equal
    weights: NumPy's ``hazen`` quantiles)."""
    order = np.argsort(x, kind="stable")
    xs, ws = np.asarray(x, dtype=float)[order], np.asarray(w, dtype=float)[order]
    c = (np.cumsum(ws) - 0.5 * ws) / ws.sum()
    return np.asarray(np.interp(np.asarray(q, dtype=float), c, xs), dtype=float)


def facts(cols: Mapping[str, NDArray[np.float64]], run_names: Sequence[str],
          ev: Evidence) -> Facts:  # fmt: skip
    """The fact table of the draws in ``cols`` (the columns of :func:`runs.run_batch`)."""
    names = [f"up:{r}" for r in run_names] + [f"num:{n.key}" for n in ev.numbers]
    ups = [np.asarray(cols[f"{r}.stands"]) == 1.0 for r in run_names]
    errs = []
    for n in ev.numbers:
        x = np.asarray(cols[n.key], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            errs.append(np.where(x > 0, np.log(x / n.book), np.nan))
    log_err = np.column_stack(errs) if errs else np.zeros((len(ups[0]), 0))
    within = [np.isfinite(e) & (np.abs(e) <= ev.log_tolerance + 1e-12) for e in log_err.T]
    S = np.column_stack(ups + within)
    return Facts(tuple(names), S, log_err)


def smallest_conflicts(S: NDArray[np.bool_], names: Sequence[str], max_size: int = 3,
                       limit: int = 20) -> list[list[str]]:  # fmt: skip
    """Minimal sets of at most ``max_size`` facts that no draw satisfies together (at most
    ``limit``, smallest first, in fact order)."""
    S = np.asarray(S, dtype=bool)
    found: list[tuple[int, ...]] = []
    for size in range(1, max_size + 1):
        for combo in itertools.combinations(range(S.shape[1]), size):
            if any(set(f) <= set(combo) for f in found):
                continue
            if not np.any(np.all(S[:, combo], axis=1)):
                found.append(combo)
                if len(found) >= limit:
                    return [[names[j] for j in c] for c in found]
    return [[names[j] for j in c] for c in found]


def _largest_consistent(S: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The largest set of facts (a (J,) mask) that some draw satisfies; ties broken by the
    number of draws satisfying it, then by fact order (the lexicographically first mask)."""
    counts = S.sum(axis=1)
    best = counts.max() if S.size else 0
    cands = {tuple(row) for row in S[counts == best]}
    scored = sorted(cands, key=lambda m: (-int(np.all(S[:, list(np.nonzero(m)[0])], axis=1).sum()),
                                          tuple(not x for x in m)))  # fmt: skip
    return np.array(scored[0], dtype=bool)


@dataclass(frozen=True)
class Posterior:
    """The conditioning of the prior draws on the calibration evidence."""

    n_prior: int
    used: tuple[str, ...]  # the facts conditioned on (all, or the largest consistent subset)
    dropped: tuple[str, ...]  # facts not conditioned on (empty when all are consistent)
    conflicts: tuple[tuple[str, ...], ...]  # smallest conflicting sets (empty: consistent)
    accepted: NDArray[np.bool_]  # (N,) the consistent draws
    kernel: NDArray[np.float64]  # (N,) ABC kernel (0 outside the consistent draws)
    map_index: int  # the most probable member (-1: none)
    marginals: dict[str, dict[str, Any]]
    weights: NDArray[np.float64]  # (N,) importance weights of the accepted draws (0 elsewhere)

    @property
    def size(self) -> int:
        return int(self.accepted.sum())

    @property
    def ess(self) -> float:
        """Kish's effective sample size of the accepted draws, ``(sum w)^2 / sum w^2``."""
        w = self.weights[self.accepted]
        return float(w.sum() ** 2 / np.sum(w * w)) if w.size else 0.0

    def summary(self) -> dict[str, Any]:
        return {
            "n_prior": self.n_prior, "size": self.size, "used": list(self.used),
            "dropped": list(self.dropped), "conflicts": [list(c) for c in self.conflicts],
            "map_index": self.map_index, "marginals": self.marginals,
            "effective_size": self.ess,
        }  # fmt: skip


def consistent_subset(f: Facts) -> tuple[NDArray[np.bool_], list[list[str]]]:
    """The facts to condition on (all when some draw meets them all, else the largest
    consistent subset) and the smallest conflicting sets (empty when consistent)."""
    S = f.S
    if np.all(S, axis=1).any():
        return np.ones(S.shape[1], dtype=bool), []
    mask = _largest_consistent(S) if S.shape[0] else np.zeros(S.shape[1], dtype=bool)
    return mask, smallest_conflicts(S, f.names)


def condition(f: Facts, params: Mapping[str, NDArray[np.float64]],
              bounds: Mapping[str, tuple[float, float]], ev: Evidence, *,
              weights: NDArray[np.float64] | None = None,
              used: Sequence[str] | None = None,
              conflicts: Sequence[Sequence[str]] = ()) -> Posterior:  # fmt: skip
    """Condition the draws (their unknowns ``params``: name -> (N,), prior ``bounds``) on the
    facts ``f``; see the module docstring. ``weights`` are the draws' importance weights
    against the prior (default 1: prior draws; :mod:`mwip.calibration.proposal`). ``used``:
    the facts to condition on, decided elsewhere (stage 3's chains sample the posterior that
    stages 1-2 conditioned, :mod:`mwip.calibration.chains`), with their ``conflicts``."""
    S = f.S
    n = S.shape[0]
    if used is None:
        mask, found = consistent_subset(f)
    else:
        unknown = sorted(set(used) - set(f.names))
        if unknown:
            raise ValueError(f"used: {unknown[0]!r} is not a calibration fact")
        mask = np.array([nm in set(used) for nm in f.names], dtype=bool)
        found = [list(c) for c in conflicts]
    conflicts = found
    w_all = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    accepted = np.all(S[:, mask], axis=1) if n else np.zeros(0, dtype=bool)
    num_used = np.array([mask[len(f.names) - f.log_err.shape[1] + k]
                         for k in range(f.log_err.shape[1])], dtype=bool)  # fmt: skip
    e = np.nan_to_num(f.log_err[:, num_used], nan=np.inf) / ev.kernel_scale
    kernel = np.where(accepted, np.exp(-0.5 * np.sum(e**2, axis=1)), 0.0)
    map_index = int(np.argmax(kernel)) if accepted.any() else -1
    marg: dict[str, dict[str, Any]] = {}
    for name, vals in params.items():
        lo, hi = bounds[name]
        v = np.asarray(vals, dtype=float)[accepted]
        wv = w_all[accepted]
        width_prior = 0.9 * (hi - lo)
        entry: dict[str, Any] = {"prior": [lo, hi], "n": int(v.size)}
        if v.size:
            q5, q50, q95 = (float(x) for x in weighted_quantile(v, wv, [0.05, 0.5, 0.95]))
            entry.update(q05=q5, median=q50, q95=q95,
                         mean=float(np.sum(wv * v) / np.sum(wv)))  # fmt: skip
            ratio = (q95 - q5) / width_prior if width_prior > 0 else 0.0
            entry["width_ratio"] = float(ratio)
            entry["identified"] = bool(v.size >= 5 and ratio < ev.identified)
        else:
            entry["identified"] = False
        marg[name] = entry
    return Posterior(
        n_prior=n, used=tuple(nm for nm, m in zip(f.names, mask, strict=True) if m),
        dropped=tuple(nm for nm, m in zip(f.names, mask, strict=True) if not m),
        conflicts=tuple(tuple(c) for c in conflicts), accepted=accepted, kernel=kernel,
        map_index=map_index, marginals=marg, weights=np.where(accepted, w_all, 0.0),
    )  # fmt: skip

