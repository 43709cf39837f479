"""Gymnasium environments of the MWIP (optional: ``pip install mwip[gym]``).

Importing this module registers

- ``MwipBalance-v0``: keep the robot upright from a random lean (:class:`MwipEnv`,
  ``task="balance"``);
- ``MwipTrack-v0``: balance while tracking a random forward speed and yaw rate
  (``task="track"``);

each with a vectorised form over the batch engine (:class:`MwipVectorEnv`) for
``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``.

>>> import gymnasium, mwip.gym
>>> env = gymnasium.make("MwipBalance-v0")
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

__all__ = ["MwipEnv", "MwipVectorEnv", "EnvConfig", "ENV_IDS", "WHEEL_TORQUE_LIMIT",
           "FALL_PENALTY"]  # fmt: skip

#: The registered environment ids and their task.
ENV_IDS = {"MwipBalance-v0": "balance", "MwipTrack-v0": "track"}

for _id, _task in ENV_IDS.items():
    if _id not in gymnasium.registry:
        gymnasium.register(
            id=_id,
            entry_point="mwip.gym.env:MwipEnv",
            vector_entry_point="mwip.gym.vector:MwipVectorEnv",
            kwargs={"task": _task},
        )
