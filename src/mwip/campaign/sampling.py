"""Drawing samples: sample ``i`` depends on the campaign seed and ``i`` alone.

Sample ``i`` gets its own generator, ``numpy.random.default_rng(SeedSequence(seed,
spawn_key=(0, i)))``, and draws one uniform number per random quantity, in file order
(robot uncertainty, then initial state, then the disturbance's choice). So the same index gives
the same robot, initial state and disturbance in any run, any chunk and for every controller
(common random numbers), and adding samples never changes the earlier ones. Grid axes are not
drawn: sample ``i`` takes grid point ``i mod G`` (C order over the axes in file order).

From a uniform ``u``: ``uniform`` a gives ``c (1 + a (2u - 1))``; ``normal`` s gives
``c (1 + s z)`` with ``z = Phi^-1(Phi(-3) + u (Phi(3) - Phi(-3)))``, a standard normal cut at
+-3; ``values`` gives element ``floor(u n)``; an initial-state ``uniform = [lo, hi]`` gives
``lo + u (hi - lo)``.

The sensor noise of block ``b`` (the numerical unit, :mod:`mwip.campaign.execute`) is seeded
from ``SeedSequence(seed, spawn_key=(1, b))``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr, ndtri

from mwip.campaign.spec import INITIAL_KEYS, Campaign, Dist

__all__ = ["draw", "block_seed", "sample_rng"]


def sample_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of sample ``index`` of a campaign with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0, int(index))))


def block_seed(seed: int, block: int) -> int:
    """The sensor-noise seed of block ``block``."""
    ss = np.random.SeedSequence(seed, spawn_key=(1, int(block)))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


_CUT = 3.0


def _from_uniform(d: Dist, u: NDArray[np.float64], centre: float) -> NDArray[np.float64]:
    if d.kind == "uniform" and len(d.args) == 1:
        return centre * (1.0 + d.args[0] * (2.0 * u - 1.0))
    if d.kind == "uniform":
        lo, hi = d.args
        return lo + u * (hi - lo)
    if d.kind == "normal":
        a, b = ndtr(-_CUT), ndtr(_CUT)
        z = np.clip(ndtri(a + u * (b - a)), -_CUT, _CUT)
        return centre * (1.0 + d.args[0] * z)
    if d.kind == "values":
        vals = np.asarray(d.args)
        return vals[np.minimum((u * vals.size).astype(np.int64), vals.size - 1)]
    raise AssertionError(d.kind)


def draw(campaign: Campaign, indices: NDArray[np.int64]) -> dict[str, NDArray]:
    """The inputs of samples ``indices``: one array per column (parameters that vary, the six
    initial-state coordinates ``theta0`` ..., ``disturbance`` label)."""
    idx = np.asarray(indices, dtype=np.int64)
    named: list[tuple[str, Dist, float]] = [
        (k, d, float(getattr(campaign.centre, k))) for k, d in campaign.uncertainty
    ] + [(f"{k}0", d, 0.0) for k, d in campaign.initial]
    random = [(k, d, c) for k, d, c in named if d.kind not in ("fixed", "grid")]
    n_dist = len(campaign.disturbances)
    slots = len(random) + (1 if n_dist > 1 else 0)
    U = np.empty((idx.size, slots))
    for j, i in enumerate(idx):
        U[j] = sample_rng(campaign.seed, int(i)).random(slots)
    cols: dict[str, NDArray] = {"sample": idx.copy()}
    for s, (k, d, c) in enumerate(random):
        cols[k] = _from_uniform(d, U[:, s], c)
    axes = campaign.grid_axes
    if axes:
        shape = tuple(int(d.args[2]) for _, d in axes)
        pos = np.unravel_index(idx % int(np.prod(shape)), shape)
        for (k, d), p in zip(axes, pos, strict=True):
            cols[k] = d.grid_values()[p]
    for k, d, _ in named:
        if d.kind == "fixed":
            cols[k] = np.full(idx.size, d.args[0])
    out: dict[str, NDArray] = {"sample": cols["sample"]}
    for k, _d in campaign.uncertainty:
        out[k] = np.asarray(cols[k], dtype=float)
    for k in INITIAL_KEYS:
        out[f"{k}0"] = np.asarray(cols.get(f"{k}0", np.zeros(idx.size)), dtype=float)
    labels = np.array([label for label, _ in campaign.disturbances], dtype=object)
    choice = (
        np.minimum((U[:, -1] * n_dist).astype(np.int64), n_dist - 1)
        if n_dist > 1
        else np.zeros(idx.size, dtype=np.int64)
    )
    out["disturbance"] = labels[choice]
    return out
