"""Stage 3 of the book calibration: Metropolis chains inside the conditioned set.

The posterior of the book calibration is the twin prior (uniform on a box ``B``) restricted to
the twins that meet the conditioned facts ``F`` (:mod:`mwip.calibration.posterior`):
``pi(x) ∝ 1_B(x) 1_F(x)``. Stages 1-2 estimate it by (importance-weighted) independent draws,
which leave it with a handful of members when ``F`` is a thin set. Here ``chains`` random-walk
Metropolis chains (Metropolis et al. 1953; Hastings 1970) sample it directly: from state ``x``
propose ``x' = R(x + s L z)``, ``z ~ N(0, I)``, with ``R`` the reflection into the box
(``lo + |v - lo|`` then ``hi - |hi - v|``, repeated: the folded Gaussian kernel of a box is
symmetric, ``q(x -> x') = q(x' -> x)``, since each image of ``x'`` about the walls pairs with
an image of ``x``). The Hastings ratio under ``pi`` is then ``1_F(x')``: the move is accepted
exactly when the proposed twin meets every fact (no random number needed). Reflection rather
than rejection at the walls matters here: the twins that stand lie against several walls at
once (no dead-band, no friction, the lowest gear ratio), where most unreflected steps would
leave the box. Unknowns the prior fixes (``low = high``) never move.

Adaptation, burn-in only (then the kernel is fixed, so the kept draws come from a
time-homogeneous chain whose stationary law is ``pi``; Roberts & Rosenthal 2009 discuss why
adapting only during burn-in is safe):

- until the first update, ``L = diag(w)`` (``w`` the prior widths), ``s`` from ``scale``;
- every ``adapt_every`` generations of the burn-in, ``L = chol(Sigma)`` with ``Sigma`` the
  covariance of every chain's states over the window before (Haario, Saksman & Tamminen
  2001), and ``s`` rescaled so that the mean squared step in prior-width units,
  ``s^2 tr(W^-1 L L^T W^-1)``, stays what it was (the acceptance depends mostly on the step's
  size, so a new shape does not undo the scale's adaptation);
- after each burn-in generation ``ln s += (a_g - accept) / sqrt(j)``, ``a_g`` the fraction of
  chains that moved, ``j`` the generation's index since the last update (Robbins-Monro);
- the kept generations ``burn + 1 .. steps`` use the last ``L`` and the ``s`` the burn-in
  left: the kernel that was adapted last.

Every covariance gets ``1e-12 diag(w^2)`` so that its factor exists. Generation ``g`` draws its
normals from the generator of ``(seed, g)`` alone (:func:`mwip.campaign.sampling.sample_rng`),
so the chains are deterministic for a seed. Each generation (its proposals, which were inside
the box, which moved, and the evaluated columns) is stored as ``store/gen-NNN.parquet``; a
rerun replays the stored generations without evaluating them again and goes on from there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["ChainPlan", "ChainResult", "reflect", "run_chains"]

Cols = dict[str, NDArray[np.float64]]


@dataclass(frozen=True)
class ChainPlan:
    """``chains`` chains of ``steps`` generations, the first ``burn`` adapting and discarded;
    first step ``scale`` (fraction of each prior width), target acceptance ``accept``, the
    step's shape updated every ``adapt_every`` burn-in generations; the sample counts as
    converged when every moving unknown's split R-hat is below ``converged``."""

    chains: int
    steps: int
    burn: int
    seed: int
    scale: float = 0.05
    accept: float = 0.234
    adapt_every: int = 25
    converged: float = 1.1

    def __post_init__(self) -> None:
        def integer(name: str, lo: int, hi: int) -> None:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise ValueError(f"chains.{name} must be an integer in [{lo}, {hi}], got {v!r}")

        integer("chains", 2, 100_000)
        integer("burn", 2, 100_000)
        integer("steps", self.burn + 4 if isinstance(self.burn, int) else 6, 1_000_000)
        integer("seed", 0, 2**63 - 1)
        integer("adapt_every", 2, 100_000)
        if not (1.0 < float(self.converged) <= 2.0):
            raise ValueError(f"chains.converged must be in (1, 2], got {self.converged!r}")
        if not (0.0 < float(self.scale) <= 1.0):
            raise ValueError(f"chains.scale must be in (0, 1], got {self.scale!r}")
        if not (0.0 < float(self.accept) < 1.0):
            raise ValueError(f"chains.accept must be in (0, 1), got {self.accept!r}")

    @property
    def kept(self) -> int:
        """Generations kept per chain."""
        return self.steps - self.burn


@dataclass(frozen=True)
class ChainResult:
    """The kept draws and what the chains did.

    ``x`` (C, K, D) the unknowns of every chain's kept states, ``cols`` the evaluated columns
    of those states (name -> (C, K)), ``proposals`` every evaluated proposal (a DataFrame:
    ``chain``, ``generation``, ``param.<name>``, the columns), ``moved`` (C, steps) which
    generations moved each chain, ``scale`` the final step factor, ``evaluations`` the
    proposals evaluated (inside the box)."""

    names: tuple[str, ...]
    x: NDArray[np.float64]
    cols: dict[str, NDArray[np.float64]]
    proposals: Any
    moved: NDArray[np.bool_]
    inside: NDArray[np.bool_]
    scale: float
    burn: int
    plan: ChainPlan | None = None

    @property
    def evaluations(self) -> int:
        return int(self.inside.sum())

    def acceptance(self, kept: bool = True) -> float:
        """Fraction of proposals that moved a chain (over the kept generations by default)."""
        m = self.moved[:, self.burn:] if kept else self.moved
        return float(m.mean()) if m.size else float("nan")


def _chol(cov: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    free = w > 0
    L = np.zeros_like(cov)
    sub = cov[np.ix_(free, free)] + 1e-12 * np.diag(w[free] ** 2)
    L[np.ix_(free, free)] = np.linalg.cholesky(sub)
    return L


def reflect(v: NDArray[np.float64], bounds: NDArray[np.float64]) -> NDArray[np.float64]:
    """``v`` (N, D) folded into the box ``bounds`` (D, 2) by reflection at its walls
    (unknowns with ``low = high`` are set to ``low``): ``lo + |v - lo|``, then
    ``hi - |hi - v|``, which for any ``v`` is the periodic fold of period ``2 (hi - lo)``."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    w = hi - lo
    out = np.array(v, dtype=float, copy=True)
    free = w > 0
    u = np.mod(out[:, free] - lo[free], 2.0 * w[free])
    out[:, free] = lo[free] + np.where(u > w[free], 2.0 * w[free] - u, u)
    out[:, ~free] = lo[~free]
    return out


def _take(cols: Mapping[str, NDArray[np.float64]], idx: NDArray[np.int64]) -> Cols:
    return {k: np.asarray(v, dtype=float)[idx] for k, v in cols.items()}


def _claim(store: Path, plan: ChainPlan, names: Sequence[str], bounds: NDArray[np.float64],
           start: NDArray[np.float64]) -> None:  # fmt: skip
    """Record what the stored generations belong to (``store/plan.json``); a folder holding
    another plan's generations is a ``ValueError`` (they would be replayed as this one's)."""
    from dataclasses import asdict

    from mwip.calibration.stored import claim_folder

    claim_folder(store, {"plan": asdict(plan), "names": list(names), "bounds": bounds.tolist(),
                         "start": np.asarray(start, dtype=float).tolist()},
                 "generations of another chain plan or start")  # fmt: skip


def run_chains(
    plan: ChainPlan,
    names: Sequence[str],
    bounds: NDArray[np.float64],
    start: NDArray[np.float64],
    start_cols: Mapping[str, NDArray[np.float64]],
    evaluate: Callable[[dict[str, NDArray[np.float64]]], Cols],
    consistent: Callable[[Mapping[str, NDArray[np.float64]]], NDArray[np.bool_]],
    *,
    store: Path | None = None,
    note: Callable[[str], None] | None = None,
) -> ChainResult:
    """Run (or resume from ``store``) the chains of ``plan`` (module docstring).

    ``names`` / ``bounds`` (D, 2): the prior's unknowns and box; ``start`` (K, D) consistent
    states and ``start_cols`` their columns (name -> (K,)), chain ``c`` starting at state
    ``c mod K``; ``evaluate(values)`` the columns of a batch of twins (name -> (n,));
    ``consistent(cols)`` which of them meet every conditioned fact. A start state that is not
    consistent is a ``ValueError`` (the chain would target nothing)."""
    import pandas as pd

    from mwip.campaign.sampling import sample_rng
    from mwip.io import write_parquet_atomic

    b = np.asarray(bounds, dtype=float)
    w = b[:, 1] - b[:, 0]
    x0 = np.atleast_2d(np.asarray(start, dtype=float))
    if x0.shape[0] < 1 or x0.shape[1] != len(names):
        raise ValueError(f"start must be (K >= 1, {len(names)}), got {x0.shape}")
    if not np.all(consistent(start_cols)):
        raise ValueError("a start state does not meet the conditioned facts")
    if store is not None:
        _claim(store, plan, names, b, x0)
    C = plan.chains
    pick = np.arange(C) % x0.shape[0]
    x = x0[pick].copy()
    cur = _take(start_cols, pick)
    keys = sorted(cur)
    updates = tuple(range(plan.adapt_every, plan.burn, plan.adapt_every))
    log_s = float(np.log(plan.scale))
    L = np.diag(w)
    wn = np.where(w > 0, w, 1.0)
    history = np.zeros((plan.steps, C, len(names)))
    kept_cols = {k: np.zeros((C, plan.kept)) for k in keys}
    moved = np.zeros((C, plan.steps), dtype=bool)
    inside_all = np.zeros((C, plan.steps), dtype=bool)
    props = []
    from mwip.calibration.clock import StepClock

    clock = StepClock(plan.steps)
    for g in range(plan.steps):
        if g in updates:  # the states of the window before shape the steps
            lo = g - plan.adapt_every
            new = _chol(np.cov(history[lo:g].reshape(-1, len(names)), rowvar=False), w)
            size_old = float(np.sum((L / wn[:, None]) ** 2))
            size_new = float(np.sum((new / wn[:, None]) ** 2))
            if size_new > 0:
                log_s += 0.5 * np.log(size_old / size_new)
                L = new
        path = store / f"gen-{g:04d}.parquet" if store is not None else None
        if path is not None and path.exists():
            df = pd.read_parquet(path)
        else:
            z = sample_rng(plan.seed, g).standard_normal((C, len(names)))
            prop = reflect(x + np.exp(log_s) * z @ L.T, b)
            prop[:, w == 0] = x[:, w == 0]
            inb = np.all((prop >= b[:, 0]) & (prop <= b[:, 1]), axis=1)
            idx = np.nonzero(inb)[0]
            ok = np.zeros(C, dtype=bool)
            ev: Cols = {k: np.full(C, np.nan) for k in keys}
            if idx.size:
                got = evaluate({n: prop[idx, j].copy() for j, n in enumerate(names)})
                ok[idx] = np.asarray(consistent(got), dtype=bool)
                for k in keys:
                    ev[k][idx] = np.asarray(got[k], dtype=float)
            df = pd.DataFrame({"chain": np.arange(C), "generation": g, "inside": inb,
                               "moved": ok, **{f"param.{n}": prop[:, j]
                                               for j, n in enumerate(names)}, **ev})  # fmt: skip
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                write_parquet_atomic(path, df)
            clock.ran(g)
        ok = df["moved"].to_numpy(dtype=bool)
        inside_all[:, g] = df["inside"].to_numpy(dtype=bool)
        moved[:, g] = ok
        prop = df[[f"param.{n}" for n in names]].to_numpy(dtype=float)
        x[ok] = prop[ok]
        for k in keys:
            cur[k][ok] = df[k].to_numpy(dtype=float)[ok]
        history[g] = x
        if g >= plan.burn:
            for k in keys:
                kept_cols[k][:, g - plan.burn] = cur[k]
        else:
            j = g + 1 - max((t for t in updates if t <= g), default=0)
            log_s += (float(ok.mean()) - plan.accept) / np.sqrt(j)
        props.append(df[df["inside"]])
        if note is not None:
            note(f"chains: generation {g + 1}/{plan.steps}, {int(ok.sum())}/{C} moved"
                 f"{clock.left(g)}")
    proposals = pd.concat(props, ignore_index=True) if props else pd.DataFrame()
    return ChainResult(
        names=tuple(names), x=np.transpose(history[plan.burn:], (1, 0, 2)).copy(),
        cols=kept_cols, proposals=proposals, moved=moved, inside=inside_all,
        scale=float(np.exp(log_s)), burn=plan.burn, plan=plan,
    )  # fmt: skip

