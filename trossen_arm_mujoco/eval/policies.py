"""The policies ``trossen-mujoco eval`` runs: what ``--policy`` names, made ready for one env.

- ``scripted``: the task's scripted policy, as ``record`` runs it (the reference row);
- ``module:function``: a plain callable ``function(observation) -> action`` in the env's
  layout (an optional ``reset()`` attribute is called at every episode start);
- a path: a LeRobot ``PreTrainedPolicy`` checkpoint (``eval.lerobot_policy``).

Every policy has ``reset(env)`` (called after ``env.reset``) and ``act(observation)``.

Docs: docs/cli/eval.md; the scripted variants: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.env import KitPolicyEnv, episode_generator
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT

__all__ = [
    "ArmScriptedPolicy",
    "ClosedLoopScriptedPolicy",
    "FunctionPolicy",
    "Policy",
    "ScriptedPolicy",
    "is_function_spec",
    "make_policy",
]


class Policy(Protocol):
    """What the eval runner drives: ``reset`` at each episode, ``act`` every step,
    ``close`` once at the end."""

    def reset(self, env: KitPolicyEnv, seed: int) -> None:
        """Start an episode of ``env`` drawn from ``seed``."""

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The action for ``observation`` (the env's observation dict): a (action dim,)
        float array in the env's layout."""

    def close(self) -> None:
        """Release what the policy holds (envs, models)."""


class ClosedLoopScriptedPolicy:
    """The scripted policy of a task that acts in a joint layout (``action_layout``, e.g.
    ``mobile_pick_place``'s ``mobileai``), as ``record`` runs it: made with the episode's
    task at every reset and acting closed-loop on the task's own observation (the env's
    running episode), its actions in the env's layout."""

    def __init__(self, policy_cls: type, env: KitPolicyEnv):
        layout = str(policy_cls.action_layout)
        if layout != env.layout_name:
            raise UserError(
                f"--policy scripted acts in the {layout} layout; the env is in "
                f"{env.layout_name}: pass --layout {layout}"
            )
        self.policy_cls = policy_cls
        self._env = env
        self._policy: Any = None

    def reset(self, env: KitPolicyEnv, seed: int) -> None:
        """A fresh policy on ``env``'s episode (no noise; its generator from ``seed``)."""
        self._env = env
        self._policy = self.policy_cls(env.task, inject_noise=False, rng=episode_generator(seed))

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The policy's action for the episode's observation now, (layout size,)."""
        return np.asarray(self._policy(self._env.task.get_observation()), dtype=float)

    def close(self) -> None:
        """Nothing to release (the env is the caller's)."""
        self._policy = None


class ScriptedPolicy:
    """The task's scripted policy for the episode ``env`` was reset to (see the module
    docstring). Its EE world is built once and reused."""

    def __init__(self, task: str):
        from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings

        self.recorder = EpisodeRecorder(RecordSettings(task_name=task))
        self._plan = np.zeros((0, KIT14_LAYOUT.size))
        self._t = 0

    def reset(self, env: KitPolicyEnv, seed: int) -> None:
        """Plan the episode: run the task's scripted rollout on ``env``'s object poses
        (seeded like ``record``), resampled to the env's fps when it differs."""
        src_dt = self.recorder.policy_dt
        native_len = int(round(env.episode_length / env.fps / src_dt))
        self.recorder.settings = type(self.recorder.settings)(
            task_name=env.task_name, episode_len=max(native_len, 1)
        )
        actions, _ = self.recorder.scripted_rollout(
            episode_generator(seed), object_poses=env.object_poses()
        )
        source_fps = round(1.0 / src_dt)
        if round(env.fps) != source_fps:
            from trossen_arm_mujoco.export.lerobot_plan import frame_map

            actions = frame_map(len(actions), source_fps, round(env.fps)).actions(actions)
        self._plan = (
            actions if env.layout.size == actions.shape[1] else (env.layout.from_vendor(actions))
        )
        self._t = 0

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The next planned action, (14,) kit values; the last one again after the plan ends."""
        row = self._plan[min(self._t, len(self._plan) - 1)]
        self._t += 1
        return row

    def close(self) -> None:
        """Close the recorder that plans the episodes."""
        self.recorder.close()


class ArmScriptedPolicy:
    """A single arm's scripted policy for the episode ``env`` was reset to (see the module
    docstring); its end-effector world is built once and reused."""

    def __init__(self, task: str, randomize: bool = False):
        from trossen_arm_mujoco.collect.pipeline import RecordSettings
        from trossen_arm_mujoco.collect.single_arm import SingleArmRecorder

        self.recorder = SingleArmRecorder(RecordSettings(task_name=task, randomize=randomize))
        self._plan = np.zeros((0, 7))
        self._t = 0

    def reset(self, env: Any, seed: int) -> None:
        """Plan the episode: the scripted rollout of ``env``'s episode (the same draws,
        the env's object poses and goal), resampled to the env's fps when it differs."""
        import dataclasses

        src_dt = self.recorder.policy_dt
        native_len = max(1, int(round(env.episode_length / env.fps / src_dt)))
        self.recorder.settings = dataclasses.replace(self.recorder.settings, episode_len=native_len)
        actions, _ = self.recorder.scripted_rollout(
            episode_generator(seed), object_poses=env.object_poses(), goal=env.goal()
        )
        source_fps = round(1.0 / src_dt)
        if round(env.fps) != source_fps:
            from trossen_arm_mujoco.export.lerobot_plan import frame_map

            actions = frame_map(len(actions), source_fps, round(env.fps)).actions(actions)
        self._plan = np.asarray(actions, dtype=float)
        self._t = 0

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The next planned action, (7,); the last one again after the plan ends."""
        row = self._plan[min(self._t, len(self._plan) - 1)]
        self._t += 1
        return row

    def close(self) -> None:
        """Close the recorder that plans the episodes."""
        self.recorder.close()


class FunctionPolicy:
    """``module:function`` (see the module docstring)."""

    def __init__(self, spec: str):
        module, _, name = spec.partition(":")
        here = os.getcwd()  # the console script does not put the current folder on sys.path
        if here not in sys.path and "" not in sys.path:
            sys.path.append(here)
        try:
            fn = getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError) as exc:
            raise UserError(
                f"--policy {spec}: cannot import it ({exc}); give module:function "
                "importable from the current folder or PYTHONPATH"
            ) from None
        if not callable(fn):
            raise UserError(f"--policy {spec} is not callable")
        self.fn = fn

    def reset(self, env: KitPolicyEnv, seed: int) -> None:
        """Call the function's ``reset()`` when it has one."""
        reset = getattr(self.fn, "reset", None)
        if callable(reset):
            reset()

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """``fn(observation)`` as a float array, (action dim,)."""
        return np.asarray(self.fn(observation), dtype=float)

    def close(self) -> None:
        """Nothing to release."""
        pass


def is_function_spec(spec: str) -> bool:
    """``module:function`` rather than a path (a path with a colon that exists wins)."""
    module, sep, name = spec.partition(":")
    return (
        bool(sep)
        and module.replace(".", "").replace("_", "").isalnum()
        and (name.isidentifier() and not Path(spec).exists())
    )


def make_policy(spec: str, env: KitPolicyEnv, device: str = "cpu") -> Policy:
    """The policy ``--policy spec`` names, checked against ``env``'s features.

    Args:
        spec: ``scripted``, ``module:function`` or a checkpoint folder.
        env: the env the policy acts in (``KitPolicyEnv`` or ``ArmPolicyEnv``).
        device: torch device of a checkpoint's policy.
    """
    if spec == "scripted":
        from trossen_arm_mujoco.tasks import registry

        policy_cls = registry.load(env.task_name).policy_class()
        from trossen_arm_mujoco.collect.single_arm import is_arm_ee_policy

        if is_arm_ee_policy(policy_cls):  # one arm's tool poses, planned as record does
            return ArmScriptedPolicy(
                env.task_name, randomize=bool(getattr(env, "randomize", False))
            )
        if getattr(policy_cls, "action_layout", "ee") != "ee":  # acts in joint space
            return ClosedLoopScriptedPolicy(policy_cls, env)
        return ScriptedPolicy(env.task_name)
    if is_function_spec(spec):
        return FunctionPolicy(spec)
    from trossen_arm_mujoco.eval.lerobot_policy import LeRobotPolicy

    return LeRobotPolicy(spec, env, device=device)
