"""The vectorised MWIP environment: N robots in one batch of the compiled engine.

``gymnasium.make_vec("mwip/Balance-v0", num_envs=N, vectorization_mode="vector_entry_point")``
(or :class:`MwipVectorEnv` directly) steps N robots with one call of the plant kernel per
sample, the same code path as a Monte Carlo batch of :func:`mwip.sim.simulate`. Each robot may
have its own parameters (``plant`` with array fields of shape (N,), e.g. varied +-20 %).
Observations, rewards and episode ends are those of :class:`mwip.gym.env.MwipEnv`, and an
episode is truncated after ``max_episode_steps`` (``make_vec`` passes the registered 2000;
directly: ``episode_seconds``, default 10 s): Gymnasium wraps no vector env in a time limit.
Robots whose episode ended are reset on the next call of :meth:`step` (Gymnasium's "next
step" autoreset: that step's action is ignored for them and they return their new first
observation).

Measurements are ideal, optionally with additive white Gaussian noise of standard deviation
``obs_noise`` (7,) on the observation (a per-robot sensor with memory, like the twin's IMU
fusion, cannot be reset robot by robot; use :class:`MwipEnv` with a twin sensor for that).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import ArrayLike, NDArray

from mwip.gym.env import FALL_PENALTY, EnvConfig, advance, observation, reward
from mwip.models.reduced import coefficients
from mwip.params import REAL, Params
from mwip.sim.kernel import OK

__all__ = ["MwipVectorEnv"]


class MwipVectorEnv(VectorEnv):
    """N robots stepped together (module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 16,
        *,
        plant: Params | None = None,
        obs_noise: ArrayLike = 0.0,
        **config: Any,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if config.get("robot") is not None:  # EnvConfig reads it: its body is the plant
            self.cfg = EnvConfig(plant=plant, **config)
            plant = self.cfg.plant
        else:
            plant = REAL if plant is None else plant
            shape = plant.batch_shape
            if shape not in ((), (num_envs,)):
                raise ValueError(f"plant fields must be scalars or of shape ({num_envs},), "
                                 f"got {shape}")  # fmt: skip
            self.cfg = EnvConfig(plant=plant[0] if shape else plant, **config)
        self.num_envs = num_envs
        self.plant = plant
        self.coef = np.ascontiguousarray(
            np.broadcast_to(coefficients(plant).reshape(-1, 10), (num_envs, 10))
        )
        self.r = np.broadcast_to(np.asarray(plant.r, dtype=float), (num_envs,)).copy()
        noise = np.broadcast_to(np.asarray(obs_noise, dtype=float), (7,))
        if not (np.all(np.isfinite(noise)) and np.all(noise >= 0)):
            raise ValueError(f"obs_noise must be finite and >= 0, got {obs_noise!r}")
        self.obs_noise = noise.copy()
        self.single_observation_space, self.single_action_space = self.cfg.spaces()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._y = np.zeros((num_envs, 8))
        self._refs = np.zeros((num_envs, 2))
        self._k = np.zeros(num_envs, dtype=np.int64)
        self._done = np.zeros(num_envs, dtype=bool)
        self._rng = np.random.default_rng()

    def _reset_rows(self, rows: NDArray[np.bool_]) -> None:
        m = int(rows.sum())
        if m == 0:
            return
        c = self.cfg
        self._y[rows] = 0.0
        self._y[rows, 1] = self._rng.uniform(-c.init_theta, c.init_theta, m)
        if c.task == "track":
            self._refs[rows, 0] = self._rng.uniform(-c.v_ref_range, c.v_ref_range, m)
            self._refs[rows, 1] = self._rng.uniform(-c.yaw_rate_ref_range, c.yaw_rate_ref_range, m)
        self._k[rows] = 0

    def _obs(self) -> NDArray[np.float32]:
        obs = observation(self._y, self.r, self._refs)
        if np.any(self.obs_noise > 0):
            obs = obs + (self._rng.standard_normal(obs.shape) * self.obs_noise).astype(np.float32)
        return np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Reset every robot (a seed makes the whole batch reproducible)."""
        if isinstance(seed, list):
            seed = seed[0] if seed else None
        if seed is not None:
            self._rng = np.random.default_rng(seed)
            self.single_action_space.seed(seed)
        self._reset_rows(np.ones(self.num_envs, dtype=bool))
        self._done[:] = False
        return self._obs(), {}

    def step(
        self, actions: ArrayLike
    ) -> tuple[NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_],
               dict[str, Any]]:  # fmt: skip
        c = self.cfg
        u = np.clip(np.asarray(actions, dtype=float).reshape(self.num_envs, 2), -c.max_torque,
                    c.max_torque)  # fmt: skip
        if not np.all(np.isfinite(u)):
            raise ValueError("actions must be finite")
        restart = self._done.copy()
        self._reset_rows(restart)
        u[restart] = 0.0
        # robots that restart this step do not move: advance only the others
        live = ~restart
        status = np.zeros(self.num_envs, dtype=np.int64)
        if live.any():
            y = np.ascontiguousarray(self._y[live])
            t = (self._k[live] * c.Ts).astype(np.float64)
            status[live] = advance(c, y, np.ascontiguousarray(u[live]), t,
                                   np.ascontiguousarray(self.coef[live]))  # fmt: skip
            self._y[live] = y
            self._k[live] += 1
        terminated = live & (status != OK)
        truncated = live & ~terminated & (self._k >= c.max_steps)
        rew = reward(c.task, self._y, self.r, self._refs, u, c.max_torque)
        rew[terminated] = FALL_PENALTY
        rew[restart] = 0.0
        self._done = terminated | truncated
        return self._obs(), rew, terminated, truncated, {}
