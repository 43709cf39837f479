"""Gymnasium environments of the MWIP (optional: ``pip install mwip[gym]``).

Importing this module registers, in the namespace ``mwip``,

- ``mwip/Balance-v0``: keep the robot upright from a random lean (:class:`MwipEnv`,
  ``task="balance"``);
- ``mwip/Track-v0``: balance while tracking a random forward speed and yaw rate
  (``task="track"``);

each with ``max_episode_steps`` = :data:`MAX_EPISODE_STEPS` (10 s of 5 ms steps; episodes are
truncated by Gymnasium's ``TimeLimit``, ``gymnasium.make(id, max_episode_steps=N)`` changes
it) and a vectorised form over the batch engine (:class:`MwipVectorEnv`) for
``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``. The ids of before,
``MwipBalance-v0`` and ``MwipTrack-v0``, are registered too, the same way (deprecated).

>>> import gymnasium, mwip.gym
>>> env = gymnasium.make("mwip/Balance-v0")
>>> env.spec.max_episode_steps
2000
>>> obs, info = env.reset(seed=0)
>>> obs.shape
(7,)
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise ImportError(
        "mwip.gym needs Gymnasium: pip install 'mwip[gym]' (or pip install gymnasium)"
    ) from exc

from mwip.gym.env import FALL_PENALTY, WHEEL_TORQUE_LIMIT, EnvConfig, MwipEnv
from mwip.gym.vector import MwipVectorEnv

__all__ = ["MwipEnv", "MwipVectorEnv", "EnvConfig", "ENV_IDS", "LEGACY_IDS",
           "MAX_EPISODE_STEPS", "WHEEL_TORQUE_LIMIT", "FALL_PENALTY"]  # fmt: skip

#: The registered environment ids and their task.
ENV_IDS = {"mwip/Balance-v0": "balance", "mwip/Track-v0": "track"}

#: The ids without namespace of mwip before issue 25 (deprecated; the same environments).
LEGACY_IDS = {"MwipBalance-v0": "balance", "MwipTrack-v0": "track"}

#: Registered episode length: 10 s of 5 ms samples.
MAX_EPISODE_STEPS = 2000

for _id, _task in {**ENV_IDS, **LEGACY_IDS}.items():
    if _id not in gymnasium.registry:
        gymnasium.register(
            id=_id,
            entry_point="mwip.gym.env:MwipEnv",
            vector_entry_point="mwip.gym.vector:MwipVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={"task": _task},
        )
