"""Gymnasium ids of every env, registered on ``import trossen_arm_mujoco``: each task
declares its ids (``TaskEntry.gym_ids``), those of installed packages included.

Registering builds nothing and reads no file, and is harmless twice. ``max_episode_steps``
comes from the task's YAML config, read when first asked for: a broken config fails only the
ids of its task. Every id takes the keyword arguments of ``gym.env.TrossenMujocoEnv`` and the
task's config keys::

    >>> import gymnasium as gym, trossen_arm_mujoco
    >>> env = gym.make("TrossenMujoco/WXAIPush-v0", obs_type="pixels", shadows=False)

Docs: docs/gym/index.md.
"""

from __future__ import annotations

from typing import Any

from gymnasium.envs.registration import EnvSpec

__all__ = ["ENV_IDS", "NAMESPACE", "TaskEnvSpec", "register_envs"]

NAMESPACE = "TrossenMujoco"


def _env_ids() -> dict[str, tuple[str, str, dict[str, Any]]]:
    """Every task's ``gym_ids`` (``tasks.task_entry.TaskEntry``), shipped and installed."""
    from trossen_arm_mujoco.tasks import registry
    from trossen_arm_mujoco.tasks.task_entry import GYM_KINDS

    return {
        env_id: (GYM_KINDS[kind], entry.name, {})
        for entry in registry.ENTRIES
        for env_id, kind in entry.gym_ids.items()
    }


#: env id -> (entry point, task name, extra kwargs), from the tasks' declarations.
ENV_IDS: dict[str, tuple[str, str, dict[str, Any]]] = _env_ids()


class TaskEnvSpec(EnvSpec):
    """``EnvSpec`` of a registered task whose ``max_episode_steps`` is the task's YAML value,
    read on first use (and kept); setting it replaces that.

    Args:
        *args: as for ``gymnasium.envs.registration.EnvSpec``.
        task: the registered task name ("" for no task: ``max_episode_steps`` as given).
        **kwargs: as for ``EnvSpec``.
    """

    def __init__(self, *args: Any, task: str = "", **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._task = task
        self._lazy = bool(task) and kwargs.get("max_episode_steps") is None

    @property  # type: ignore[override]
    def max_episode_steps(self) -> int | None:
        """The task config's ``max_episode_steps`` (the TimeLimit), read from its YAML
        file the first time it is asked for."""
        if self.__dict__.get("_lazy"):
            from trossen_arm_mujoco.tasks import registry

            config = registry.load(self._task).load_config()
            self._steps, self._lazy = int(config["max_episode_steps"]), False
        return self.__dict__.get("_steps")

    @max_episode_steps.setter
    def max_episode_steps(self, value: int | None) -> None:
        self._steps, self._lazy = value, False


def register_envs() -> list[str]:
    """Register every id not yet in ``gymnasium.registry``; returns the ids registered now.
    No config is read (see ``TaskEnvSpec``)."""
    import gymnasium

    added = []
    for env_id, (entry_point, task, kwargs) in ENV_IDS.items():
        if env_id in gymnasium.registry:
            continue
        kwargs = {"task": task, **kwargs}
        gymnasium.register(id=env_id, entry_point=entry_point, kwargs=kwargs)  # its checks
        gymnasium.registry[env_id] = TaskEnvSpec(
            id=env_id, entry_point=entry_point, kwargs=kwargs, task=task
        )
        added.append(env_id)
    return added
