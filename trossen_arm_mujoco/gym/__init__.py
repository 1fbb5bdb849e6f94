"""Gymnasium front door: env ids, the env adapter, goal envs and stepping regimes.

Importing this package is cheap; the env classes are imported when an env is made:
``gymnasium.make("TrossenMujoco/WXAIReach-v0")`` (ids in ``gym.registration.ENV_IDS``).

Docs: docs/gym/index.md, docs/reference/gym.md.
"""

from trossen_arm_mujoco.gym.registration import ENV_IDS, register_envs

__all__ = ["ENV_IDS", "register_envs"]
