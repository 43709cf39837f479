"""The Gymnasium environments (issue 17 item 3)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import mwip.gym  # noqa: E402
from mwip.gym import ENV_IDS, MwipEnv, MwipVectorEnv  # noqa: E402
from mwip.laws.lqr.controller import design_lqr  # noqa: E402
from mwip.params import NOMINAL, REAL  # noqa: E402
from mwip.sim import Sinusoid, simulate  # noqa: E402


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_registered_and_passes_env_checker(env_id):
    from gymnasium.utils.env_checker import check_env

    assert env_id.startswith("mwip/")
    env = gymnasium.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advice about unbounded/unnormalised boxes
        check_env(env.unwrapped)


def test_step_is_the_engine():
    """Holding a torque for k steps equals mwip.sim.simulate with the same held torque."""

    class Hold:
        Ts, static = 0.005, False

        def reset(self, meas):
            pass

        def __call__(self, t, meas):
            return np.array([[0.0625, 0.03125]])  # exact in float32, the action dtype

        def log(self):
            return {}

    env = MwipEnv(task="balance", plant=REAL)
    env.reset(seed=0, options={"theta0": 0.05})
    for _ in range(40):
        obs, *_ = env.step(np.array([0.0625, 0.03125], dtype=np.float32))
    ref = simulate(Hold(), REAL, q0=(0, 0.05, 0), duration=0.2, Ts=0.005)
    assert np.array_equal(env._y[0], ref.state[-1])
    assert obs[0] == pytest.approx(env._y[0, 1], abs=1e-6)


def test_lqr_baseline_beats_random_policy_and_falls_terminate():
    K = design_lqr(NOMINAL, Ts=0.005).K
    env = gymnasium.make("mwip/Balance-v0")
    obs, _ = env.reset(seed=3)
    total, steps = 0.0, 0
    while True:
        obs, rew, term, trunc, info = env.step((-K @ obs[:5]).astype(np.float32))
        total, steps = total + rew, steps + 1
        if term or trunc:
            break
    assert trunc and not term and steps == 2000 and total > 1900
    env.reset(seed=3)
    env.action_space.seed(3)
    for _ in range(2000):
        *_, term, trunc, info = env.step(env.action_space.sample())
        if term:
            break
    assert term and info["status"] == "fell"


def test_make_with_max_episode_steps_truncates_by_gymnasiums_time_limit():
    """Registered under the namespace with max_episode_steps: Gymnasium's TimeLimit ends the
    episode (the env itself never truncates); make(..., max_episode_steps=N) overrides it;
    the old ids are the same environments; make_vec passes the limit to the vector env."""
    from gymnasium.wrappers import TimeLimit

    for env_id in (*ENV_IDS, *mwip.gym.LEGACY_IDS):
        assert gymnasium.spec(env_id).max_episode_steps == mwip.gym.MAX_EPISODE_STEPS == 2000
    assert gymnasium.spec("mwip/Balance-v0").namespace == "mwip"
    env = gymnasium.make("mwip/Balance-v0", max_episode_steps=7)
    assert isinstance(env, TimeLimit) or any(
        isinstance(w, TimeLimit) for w in _wrappers(env)
    )  # fmt: skip
    env.reset(seed=0, options={"theta0": 0.0})
    ends = [env.step(np.zeros(2, dtype=np.float32))[3] for _ in range(7)]
    assert ends == [False] * 6 + [True]
    raw = env.unwrapped
    assert isinstance(raw, MwipEnv)
    raw.reset(seed=0, options={"theta0": 0.0})
    assert not any(raw.step(np.zeros(2, dtype=np.float32))[3] for _ in range(2100))
    with pytest.raises(TypeError, match="TimeLimit"):
        MwipEnv(episode_seconds=1.0)
    venv = gymnasium.make_vec("mwip/Balance-v0", num_envs=2, max_episode_steps=5,
                              vectorization_mode="vector_entry_point")  # fmt: skip
    venv.reset(seed=0)
    truncs = [venv.step(np.zeros((2, 2)))[3].all() for _ in range(5)]
    assert truncs == [False] * 4 + [True]
    track = gymnasium.make_vec("mwip/Track-v0", num_envs=2, vectorization_mode="vector_entry_point")
    assert track.cfg.max_steps == 2000


def _wrappers(env):
    while hasattr(env, "env"):
        yield env
        env = env.env


def test_track_task_rewards_the_reference():
    env = MwipEnv(task="track")
    obs, _ = env.reset(seed=0, options={"v_ref": 0.5, "yaw_rate_ref": -0.3})
    assert obs[5] == pytest.approx(0.5) and obs[6] == pytest.approx(-0.3)


def test_vector_env_matches_single_envs_and_autoresets():
    n = 6
    rng = np.random.default_rng(0)
    plants = REAL.__class__(**{**REAL.to_dict(), "mb": REAL.mb * rng.uniform(0.8, 1.2, n)})
    venv = MwipVectorEnv(n, plant=plants, task="balance")
    obs, _ = venv.reset(seed=1)
    y0 = venv._y.copy()
    K = design_lqr(NOMINAL, Ts=0.005).K
    actions = []
    for _ in range(50):
        a = -(obs[:, :5].astype(float) @ K.T)
        actions.append(a)
        obs, rew, term, trunc, _ = venv.step(a)
    assert not term.any()
    # each robot of the batch equals a single env with its own parameters, step by step
    for i in range(n):
        env = MwipEnv(task="balance", plant=plants[i])
        env.reset(options={"theta0": float(y0[i, 1])})
        for a in actions:
            env.step(a[i])
        assert np.allclose(env._y[0], venv._y[i], rtol=0, atol=1e-12)
    # random torques make robots fall; fallen ones restart on the next step with reward 0
    venv.reset(seed=2)
    venv.single_action_space.seed(2)
    saw_restart = False
    done_prev = np.zeros(n, dtype=bool)
    for _ in range(400):
        obs, rew, term, trunc, _ = venv.step(venv.action_space.sample())
        if done_prev.any():
            assert np.all(rew[done_prev] == 0.0) and not term[done_prev].any()
            saw_restart = True
        assert np.all(rew[term] == mwip.gym.FALL_PENALTY)
        done_prev = term | trunc
    assert saw_restart


def test_disturbance_from_scenario(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[scenario]\nTs = 0.005\n[plant]\nbase = "real"\nmb = 2.7\n'
                 '[disturbance]\nkind = "book"\n')  # fmt: skip
    env = MwipEnv(scenario=f)
    assert env.cfg.plant.mb == 2.7 and env.cfg.disturbance is not None
    env.reset(seed=0, options={"theta0": 0.0})
    env.step(np.zeros(2, dtype=np.float32))
    assert np.any(env._y[0, :6] != 0.0)  # the disturbance moved a robot at rest


def test_bad_arguments():
    with pytest.raises(ValueError, match="task must be one of balance, track"):
        MwipEnv(task="run")
    with pytest.raises(ValueError, match="max_torque"):
        MwipEnv(max_torque=-1.0)
    with pytest.raises(ValueError, match="num_envs"):
        MwipVectorEnv(0)
    with pytest.raises(ValueError, match="Ts"):
        MwipEnv(Ts=0.0)
    assert Sinusoid  # imported for the scenario disturbance kinds


def test_example_policy_script_runs():
    """examples/gym_policy_vs_lqr.py: its evaluation helper on a few robots (the training
    loop itself is the example's, minutes long)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[1] / "examples" / "gym_policy_vs_lqr.py"
    spec = importlib.util.spec_from_file_location("gym_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    K = design_lqr(NOMINAL, Ts=0.005).K
    lqr = mod.episode_returns(mod.linear(-K), seed=5, n_envs=4)
    zero = mod.episode_returns(mod.linear(np.zeros((2, 5))), seed=5, n_envs=4)
    assert lqr.min() > 1900 and zero.max() < 0.5 * lqr.min()
    W = mod.random_search(1, directions=2)
    assert W.shape == (2, 5) and np.all(np.isfinite(W))
