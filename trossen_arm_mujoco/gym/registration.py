"""Gymnasium ids of every env, registered on ``import trossen_arm_mujoco``.

Entry points are strings, so registering builds nothing; calling ``register_envs`` again
is harmless (ids already in ``gymnasium.registry`` are skipped). Episode lengths
(``max_episode_steps``) come from the tasks' YAML configs.

    >>> import gymnasium as gym, trossen_arm_mujoco
    >>> env = gym.make("TrossenMujoco/WXAIReachGoal-v0", action_mode="ee_delta")
    >>> env = gym.make("TrossenMujoco/WXAIPush-v0", obs_type="pixels", shadows=False)

Every id takes the keyword arguments of ``gym.env.TrossenMujocoEnv`` (obs_type, action_mode,
render_mode, stepping, width, height, cameras, shadows, visual) and the task's config keys.
"""

from __future__ import annotations

from typing import Any

NAMESPACE = "TrossenMujoco"
_ENV = "trossen_arm_mujoco.gym.env:TrossenMujocoEnv"
_GOAL_ENV = "trossen_arm_mujoco.gym.goal_env:TrossenMujocoGoalEnv"

#: env id -> (entry point, task name, extra kwargs)
ENV_IDS: dict[str, tuple[str, str, dict[str, Any]]] = {
    f"{NAMESPACE}/WXAIReach-v0": (_ENV, "reach", {}),
    f"{NAMESPACE}/WXAIPush-v0": (_ENV, "push", {}),
    f"{NAMESPACE}/WXAIPickPlace-v0": (_ENV, "pick_place", {}),
    f"{NAMESPACE}/StationaryAITransferCube-v0": (_ENV, "sim_transfer_cube", {}),
    f"{NAMESPACE}/StationaryAIInsertion-v0": (_ENV, "sim_insertion", {}),
    f"{NAMESPACE}/WXAIReachGoal-v0": (_GOAL_ENV, "reach", {}),
    f"{NAMESPACE}/WXAIPushGoal-v0": (_GOAL_ENV, "push", {}),
    f"{NAMESPACE}/WXAIPickPlaceGoal-v0": (_GOAL_ENV, "pick_place", {}),
}


def _max_episode_steps(task: str) -> int:
    from trossen_arm_mujoco.tasks import registry

    return int(registry.load(task).load_config()["max_episode_steps"])


def register_envs() -> list[str]:
    """Register every id not yet in ``gymnasium.registry``; returns the ids registered now."""
    import gymnasium

    added = []
    for env_id, (entry_point, task, kwargs) in ENV_IDS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point=entry_point,
            max_episode_steps=_max_episode_steps(task),
            kwargs={"task": task, **kwargs},
        )
        added.append(env_id)
    return added
