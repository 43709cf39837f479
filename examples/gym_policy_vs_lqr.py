"""Train a linear policy on the vectorised MWIP environment by random search, and compare it
with the LQR baseline and a random policy on the same episodes.

    python examples/gym_policy_vs_lqr.py [--iterations 40]

Basic random search (Mania, Guy and Recht, "Simple random search provides a competitive
approach to reinforcement learning", 2018): perturb the gain matrix W (2 x 5) in +-directions,
roll both out on a batch of robots, step along the reward differences. The LQR of Section 4.4.2
designed for the 5 ms sample period is the baseline; a good learned policy approaches it.
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium
import numpy as np

import mwip.gym  # noqa: F401  (registers the environments)
from mwip.laws.lqr.controller import design_lqr
from mwip.params import NOMINAL


def episode_returns(policy, seed: int, n_envs: int = 32) -> np.ndarray:
    """Undiscounted return of each of ``n_envs`` balance episodes (10 s) under ``policy``."""
    env = gymnasium.make_vec("mwip/Balance-v0", num_envs=n_envs,
                             vectorization_mode="vector_entry_point")  # fmt: skip
    obs, _ = env.reset(seed=seed)
    total = np.zeros(n_envs)
    alive = np.ones(n_envs, dtype=bool)
    while alive.any():
        obs, rew, term, trunc, _ = env.step(policy(obs))
        total += np.where(alive, rew, 0.0)
        alive &= ~(term | trunc)
    return total


def linear(W: np.ndarray):
    return lambda obs: obs[:, :5].astype(float) @ W.T


def random_search(iterations: int, seed: int = 0, directions: int = 8, step: float = 0.3,
                  noise: float = 0.3, verbose: bool = True) -> np.ndarray:  # fmt: skip
    """Basic random search on u = W x from W = 0 (``verbose``: a line per iteration on
    stderr, with the time left)."""
    rng = np.random.default_rng(seed)
    W = np.zeros((2, 5))
    scale = np.array([20.0, 2.0, 2.0, 2.0, 2.0])  # theta matters most: search in scaled units
    t0 = time.perf_counter()
    for it in range(iterations):
        if verbose and it:
            spent = time.perf_counter() - t0
            left = spent / it * (iterations - it)
            print(f"iteration {it}/{iterations}: {spent:.0f} s, about {left:.0f} s left",
                  file=sys.stderr, flush=True)  # fmt: skip
        deltas = rng.standard_normal((directions, 2, 5))
        plus = [episode_returns(linear(W + noise * d * scale), 1000 * it + j, 8).mean()
                for j, d in enumerate(deltas)]  # fmt: skip
        minus = [episode_returns(linear(W - noise * d * scale), 1000 * it + j, 8).mean()
                 for j, d in enumerate(deltas)]  # fmt: skip
        diff = np.array(plus) - np.array(minus)
        sigma = np.std(np.concatenate([plus, minus])) + 1e-8
        W = W + step / sigma * np.einsum("k,kij->ij", diff, deltas) / directions * scale
    return W


def main(iterations: int = 40) -> dict[str, float]:
    K = design_lqr(NOMINAL, Ts=0.005).K
    print(f"random search: {iterations} iterations of {2 * 8} rollouts of 8 robots for 10 s "
          "(the first one compiles the environment's loop)", file=sys.stderr, flush=True)
    W = random_search(iterations)
    print("evaluating LQR, the learned and a random policy on 32 robots", file=sys.stderr,
          flush=True)  # fmt: skip
    rng = np.random.default_rng(7)
    results = {
        "lqr": episode_returns(linear(-K), seed=123).mean(),
        "learned": episode_returns(linear(W), seed=123).mean(),
        "random": episode_returns(
            lambda o: rng.uniform(-5.6, 5.6, (o.shape[0], 2)), seed=123
        ).mean(),  # fmt: skip
    }
    for name, value in results.items():
        print(f"{name:>8}: mean return {value:9.1f} (max 2000 = upright and still for 10 s)")
    return results


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=40)
    try:
        main(ap.parse_args().iterations)
    except KeyboardInterrupt:  # Ctrl-C: one line, exit 130
        print("interrupted", file=sys.stderr)
        sys.exit(130)
