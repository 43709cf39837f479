"""A Gymnasium environment of the MWIP on mwip's engine: balance, or speed and yaw tracking.

One step is one sample period ``Ts`` (default 5 ms, the robot's): the agent's wheel torques
``a = [u_r, u_l]`` (N m) are held (zero-order hold) while the compiled plant kernel of
:mod:`mwip.sim.kernel` integrates the reduced model (2.33) on the *real* parameters over
``Ts / dt`` steps, exactly as :func:`mwip.sim.simulate` does for a controller. The agent sees
what a controller sees: the measurement of the sensor model (ideal by default, or any
:class:`mwip.sim.sensors.Sensor`, e.g. the digital twin's), never the plant.

Observation (float32, 7): ``[theta, alpha, theta', v, alpha', v_ref, alpha'_ref]`` with the
LQR state of Section 4.4 first (``v = r psi'`` with the plant's measured wheel rate), then the
references (zero for ``task="balance"``).

Reward per step, in (0, 1] so that staying up always pays more than falling::

    r = exp(-c),
    balance: c = (theta / 0.2)^2 + 0.01 theta'^2 + 0.01 |a / u_max|^2
    track:   c = (theta / 0.2)^2 + ((v - v_ref) / 0.5)^2 + (alpha' - alpha'_ref)^2
                 + 0.01 |a / u_max|^2

(1 upright and on target; 0.37 at theta = 0.2 rad). An episode *terminates* when the
robot falls (``|theta| >= pi/2``, SPEC.md section 2) or the state is not finite, with the
reward :data:`FALL_PENALTY` (the discounted value, at gamma = 0.99, of the steps it loses).
:class:`MwipEnv` never truncates: the time limit is Gymnasium's ``TimeLimit`` wrapper, which
``gymnasium.make("mwip/Balance-v0")`` adds with the registered ``max_episode_steps`` (2000
steps, 10 s; ``max_episode_steps=N`` to change it). The vectorised env, which Gymnasium does
not wrap, truncates after ``max_episode_steps`` (or ``episode_seconds``) itself.

Parameters, disturbances and sampling can come from a scenario TOML (:mod:`mwip.scenario`):
its ``[plant]``, ``[disturbance]``, ``Ts`` and ``dt``; or from a robot (``robot=``, a
:class:`mwip.robot.Robot` or a robot file, docs/robot.md): its body is the plant, its
firmware's sample period ``Ts`` and its drive's largest wheel torque the action bound (the
agent's torque is applied as commanded: the environment has no drive model; pass
``sensor=robot.twin.sensor(...)`` for the robot's IMU and encoders).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from mwip.models.reduced import coefficients
from mwip.params import REAL, Params
from mwip.sim.disturbance import Disturbance
from mwip.sim.engine import choose_integrator
from mwip.sim.kernel import OK, ROS2W, advance_batch
from mwip.sim.sensors import IdealSensor, Sensor

__all__ = ["MwipEnv", "EnvConfig", "observation", "reward", "WHEEL_TORQUE_LIMIT", "FALL_PENALTY"]

#: Reward of the step on which the robot falls: -1 / (1 - 0.99).
FALL_PENALTY = -100.0

#: Wheel torque bound of the action space (N m): the RE25's stall torque 0.243 N m through the
#: twin's 23:1 gearbox (mwip.hardware.motor, docs/twin.md), the most a wheel can get.
WHEEL_TORQUE_LIMIT = 5.6

TASKS = ("balance", "track")


class EnvConfig:
    """Validated settings shared by the single and the vectorised environment."""

    def __init__(
        self,
        task: str = "balance",
        plant: Params | None = None,
        Ts: float | None = None,
        dt: float | None = None,
        episode_seconds: float = 10.0,
        max_episode_steps: int | None = None,
        max_torque: float | None = None,
        init_theta: float = 0.2,
        v_ref_range: float = 1.0,
        yaw_rate_ref_range: float = 1.0,
        disturbance: Disturbance | None = None,
        scenario: str | Path | None = None,
        robot: Any = None,
    ) -> None:
        if robot is not None:
            from mwip.robot import robot_or_default

            if scenario is not None or plant is not None:
                raise ValueError("robot: give the robot, a scenario or a plant, not two (the "
                                 "robot's body is the plant)")  # fmt: skip
            robot = robot_or_default(robot)
            plant = robot.body
            Ts = robot.Ts if Ts is None else Ts
            if max_torque is None:
                max_torque = robot.wheel_torque_limit
        plant = REAL if plant is None else plant
        Ts = 0.005 if Ts is None else Ts
        max_torque = WHEEL_TORQUE_LIMIT if max_torque is None else max_torque
        if scenario is not None:
            from mwip.scenario import load_scenario

            sc = load_scenario(scenario)
            plant, Ts, dt, disturbance = sc.plant, sc.Ts, sc.dt, sc.disturbance
        if task not in TASKS:
            raise ValueError(f"task must be one of {', '.join(TASKS)}, got {task!r}")
        if plant.batch_shape not in ((),):
            raise ValueError("plant must be one robot (scalar fields) for MwipEnv")
        _positive("Ts", Ts, 1.0)
        if dt is not None:
            _positive("dt", dt, Ts)
        coef = np.ascontiguousarray(coefficients(plant).reshape(1, 10))
        # the engine's choice of integrator and step (mwip.sim.engine.choose_integrator)
        method, dt = choose_integrator(coef, float(Ts), dt)
        _positive("dt", dt, Ts)
        n_sub = int(round(Ts / dt))
        if abs(n_sub * dt - Ts) > 1e-9 * Ts:
            raise ValueError(f"dt={dt:g} must divide Ts={Ts:g} into a whole number of steps")
        _positive("episode_seconds", episode_seconds, 3600.0)
        _positive("max_torque", max_torque, 100.0)
        for name, val, hi in (("init_theta", init_theta, 1.5), ("v_ref_range", v_ref_range, 10.0),
                              ("yaw_rate_ref_range", yaw_rate_ref_range, 10.0)):  # fmt: skip
            if not (isinstance(val, int | float) and math.isfinite(val) and 0 <= val <= hi):
                raise ValueError(f"{name} must be in [0, {hi:g}], got {val!r}")
        self.task: Literal["balance", "track"] = task  # type: ignore[assignment]
        self.plant, self.Ts, self.dt, self.n_sub = plant, float(Ts), float(dt), n_sub
        if max_episode_steps is not None and (
            isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, int)
            or not 1 <= max_episode_steps <= 10**9
        ):  # fmt: skip
            raise ValueError(f"max_episode_steps must be an integer in [1, 1e9], "
                             f"got {max_episode_steps!r}")  # fmt: skip
        self.max_steps = (max(int(round(episode_seconds / Ts)), 1) if max_episode_steps is None
                          else max_episode_steps)  # fmt: skip
        self.max_torque, self.init_theta = float(max_torque), float(init_theta)
        self.v_ref_range, self.yaw_rate_ref_range = float(v_ref_range), float(yaw_rate_ref_range)
        self.disturbance = disturbance
        self.coef = coef
        self.method = method

    def spaces(self) -> tuple[spaces.Box, spaces.Box]:
        """Observation and action spaces of one robot."""
        obs = spaces.Box(-np.inf, np.inf, shape=(7,), dtype=np.float32)
        act = spaces.Box(-self.max_torque, self.max_torque, shape=(2,), dtype=np.float32)
        return obs, act


def _positive(name: str, value: Any, hi: float) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not (math.isfinite(value) and 0 < value <= hi):
        raise ValueError(f"{name} must be in (0, {hi:g}], got {value!r}")


def observation(
    y: NDArray[np.float64], r: NDArray[np.float64] | float, refs: NDArray[np.float64]
) -> NDArray[np.float32]:
    """``[theta, alpha, theta', v, alpha', v_ref, alpha'_ref]`` (N, 7) from measured ``y``
    (N, 8) ``[psi, theta, alpha, psi', theta', alpha', x, y]``, wheel radius and references."""
    x = np.stack([y[:, 1], y[:, 2], y[:, 4], np.asarray(r) * y[:, 3], y[:, 5]], axis=1)
    return np.concatenate([x, refs], axis=1).astype(np.float32)


def reward(
    task: str, y: NDArray[np.float64], r: float | NDArray[np.float64], refs: NDArray[np.float64],
    u: NDArray[np.float64], max_torque: float,
) -> NDArray[np.float64]:  # fmt: skip
    """Per-robot reward (N,) of the module docstring, on the *true* state ``y`` (N, 8) with
    the plant's wheel radius ``r`` (scalar or (N,))."""
    th, thd = y[:, 1], y[:, 4]
    effort = 0.01 * np.sum((u / max_torque) ** 2, axis=1)
    if task == "balance":
        cost = (th / 0.2) ** 2 + 0.01 * thd**2 + effort
    else:
        v_err = r * y[:, 3] - refs[:, 0]
        w_err = y[:, 5] - refs[:, 1]
        cost = (th / 0.2) ** 2 + (v_err / 0.5) ** 2 + w_err**2 + effort
    return np.exp(-cost)


def advance(
    cfg: EnvConfig, y: NDArray[np.float64], u: NDArray[np.float64],
    t: float | NDArray[np.float64], coef: NDArray[np.float64],
) -> NDArray[np.int64]:  # fmt: skip
    """Advance the robots ``y`` (N, 8) in place over one sample with ``u`` (N, 2) held, from
    their times ``t`` (scalar or (N,): robots of a vector env restart at different times);
    returns the kernel status per robot (0 ok, 1 fell, 2 diverged)."""
    n = y.shape[0]
    # disturbance at the step boundaries (ROS2-W) or half steps (RK4), as the engine
    sub = (np.arange(cfg.n_sub + 1) * cfg.dt if cfg.method == ROS2W
           else np.arange(2 * cfg.n_sub + 1) * (0.5 * cfg.dt))  # fmt: skip
    if cfg.disturbance is None:
        tau = np.zeros((sub.size, 1, 3))
    else:
        times = np.broadcast_to(np.asarray(t, dtype=float), (n,))[None, :] + sub[:, None]
        d = np.asarray(cfg.disturbance(times.ravel()), dtype=float)
        if d.shape != (times.size, 3):
            raise ValueError("the disturbance must return (K, 3) for K times (one per robot)")
        tau = np.ascontiguousarray(d.reshape(sub.size, n, 3))
    status = np.zeros(n, dtype=np.int64)
    t_end = np.full(n, np.inf)
    t0 = float(np.min(t))  # only used by the kernel to time events, which the env ignores
    advance_batch(y, np.ascontiguousarray(u, dtype=float), tau, coef, cfg.dt, cfg.n_sub,
                  status, t0, t_end, cfg.method)  # fmt: skip
    return status


class MwipEnv(gymnasium.Env[NDArray[np.float32], NDArray[np.float32]]):
    """One MWIP: ``gymnasium.make("MwipBalance-v0")`` or ``"MwipTrack-v0"`` (module docstring).

    Keyword arguments are those of :class:`EnvConfig` plus ``sensor`` (a
    :class:`mwip.sim.sensors.Sensor`; default ideal) and ``render_mode`` (``"rgb_array"``:
    a side view drawn with matplotlib).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self, *, sensor: Sensor | None = None, render_mode: str | None = None, **config: Any
    ) -> None:
        for key in ("episode_seconds", "max_episode_steps"):
            if key in config:
                raise TypeError(
                    f"MwipEnv does not end episodes by time ({key}): gymnasium.make("
                    "'mwip/Balance-v0', max_episode_steps=N) adds Gymnasium's TimeLimit "
                    "(default 2000 steps, 10 s), or wrap it in gymnasium.wrappers.TimeLimit"
                )
        self.cfg = EnvConfig(**config)
        self.observation_space, self.action_space = self.cfg.spaces()  # type: ignore[assignment]
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / self.cfg.Ts / 10))}
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self.sensor = IdealSensor() if sensor is None else sensor
        self._y = np.zeros((1, 8))
        self._refs = np.zeros((1, 2))
        self._k = 0
        self._r = float(self.cfg.plant.r)

    def _obs(self) -> NDArray[np.float32]:
        meas = self.sensor(self._k * self.cfg.Ts, self._y)
        return observation(meas.y, self._r, self._refs)[0]

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """New episode: theta0 uniform in +-init_theta; references uniform in their ranges
        (track). ``options`` may give ``theta0``, ``v_ref``, ``yaw_rate_ref`` explicitly."""
        super().reset(seed=seed)
        opts = dict(options or {})
        rng = self.np_random
        th0 = float(opts.get("theta0", rng.uniform(-self.cfg.init_theta, self.cfg.init_theta)))
        if not (math.isfinite(th0) and abs(th0) < math.pi / 2):
            raise ValueError(f"options['theta0'] must be in (-pi/2, pi/2), got {th0!r}")
        self._y = np.zeros((1, 8))
        self._y[0, 1] = th0
        if self.cfg.task == "track":
            v = opts.get("v_ref", rng.uniform(-self.cfg.v_ref_range, self.cfg.v_ref_range))
            w = opts.get(
                "yaw_rate_ref",
                rng.uniform(-self.cfg.yaw_rate_ref_range, self.cfg.yaw_rate_ref_range),
            )
            self._refs = np.array([[float(v), float(w)]])  # fmt: skip
        else:
            self._refs = np.zeros((1, 2))
        self._k = 0
        self.sensor.reset(1, int(rng.integers(2**31)))
        return self._obs(), {"state": self._y[0].copy()}

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        u = np.clip(np.asarray(action, dtype=float).reshape(1, 2), -self.cfg.max_torque,
                    self.cfg.max_torque)  # fmt: skip
        if not np.all(np.isfinite(u)):
            raise ValueError(f"action must be finite, got {action!r}")
        status = advance(self.cfg, self._y, u, self._k * self.cfg.Ts, self.cfg.coef)
        self._k += 1
        terminated = bool(status[0] != OK)
        rew = float(reward(self.cfg.task, self._y, self._r, self._refs, u, self.cfg.max_torque)[0])
        if terminated:
            rew = FALL_PENALTY
            obs = observation(self._y, self._r, self._refs)[0]
            obs = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
        else:
            obs = self._obs()
        truncated = False  # the time limit is Gymnasium's TimeLimit (module docstring)
        info = {"state": self._y[0].copy(), "status": ("ok", "fell", "diverged")[int(status[0])]}
        return obs, rew, terminated, truncated, info

    def render(self) -> NDArray[np.uint8] | None:
        """Side view of the robot as an RGB array (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array":
            return None
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Circle

        r, ell = float(self.cfg.plant.r), float(self.cfg.plant.l)
        th, x = float(self._y[0, 1]), float(r * self._y[0, 0])
        fig = Figure(figsize=(3, 3), dpi=80)
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        ax.add_patch(Circle((x, r), r, fill=False))
        top = 2.0 * ell
        ax.plot([x, x + top * math.sin(th)], [r, r + top * math.cos(th)], lw=4)
        ax.set_xlim(x - 0.25, x + 0.25)
        ax.set_ylim(-0.02, 0.3)
        ax.set_aspect("equal")
        ax.axhline(0.0, color="k", lw=1)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()
