"""``TaskEntry``: everything the package knows about one task, declared in one place.

A task module (shipped: a module of ``trossen_arm_mujoco/tasks/`` with a module-level
``TASKS`` tuple; installed: an entry point in the group ``trossen_arm_mujoco.tasks``)
declares its tasks as ``TaskEntry`` values, and every front door derives what it needs from
them: names and aliases, gymnasium ids (``gym_ids``), config keys (``keys``, ``required``),
stages (``stages``), the scripted policy and recording defaults (``policy``, ``record``),
scene objects (``scene_objects``, ``removed_objects``). Classes may be given as import paths
``"module:Class"``, imported on first use, so listing tasks stays cheap.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks.config_key import Key

__all__ = ["GYM_KINDS", "TaskEntry", "record_defaults"]

#: Kinds of gymnasium id a task may declare: id -> kind.
GYM_KINDS: dict[str, str] = {
    "env": "trossen_arm_mujoco.gym.env:TrossenMujocoEnv",
    "goal": "trossen_arm_mujoco.gym.goal_env:TrossenMujocoGoalEnv",
}
#: Keys of ``TaskEntry.record``.
RECORD_KEYS = ("num_episodes", "episode_len", "onscreen_render", "inject_noise", "cam_names")


def record_defaults(episode_len: int, cam_names: Any = None) -> dict[str, Any]:
    """Recording defaults of a task with a scripted policy (``SIM_TASK_CONFIGS`` values):
    one episode of ``episode_len`` policy steps, no live view, no noise, the kit's cameras
    (or ``cam_names``)."""
    return {
        "num_episodes": 1,
        "episode_len": int(episode_len),
        "onscreen_render": False,
        "inject_noise": False,
        "cam_names": list(STATIONARY_CAMERAS if cam_names is None else cam_names),
    }


def import_path(value: Any) -> Any:
    """``value`` itself, or the object an import path ``"module:attr"`` names."""
    if not isinstance(value, str):
        return value
    module, _, attr = value.partition(":")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class TaskEntry:
    """One task, all its facts.

    Attributes:
        name: the task's name (what ``--task_name``, ``load`` and the gym env take).
        task: its ``Task`` subclass (reward, success, description, observations), or its
            import path ``"module:Class"``.
        sampler: its ``TaskSampler`` subclass (randomization, scene and scene objects), or
            its import path.
        config: its config: the name of a shipped YAML file in ``config/``, the path of a
            YAML file (``pathlib.Path``), or a mapping of key -> default value; checked by
            ``tasks.config_schema`` with ``keys`` and ``required``.
        description: one line for listings.
        policy: its scripted EE policy (``record``, ``eval --policy scripted``), a class or
            import path; "" when none.
        aliases: other names accepted for it.
        record: recording defaults (``record_defaults(episode_len)``); needed with a policy.
        stages: stage name -> the reward that marks it (reached when the best reward is at
            least that), in order; eval's stage-wise rates and rollout analysis.
        gym_ids: gymnasium id -> kind (``"env"``, or ``"goal"`` for goal-conditioned tasks).
        keys: config keys of this task only (``tasks.config_key.Key``), besides the
            schema's common ones.
        required: keys its config must hold (besides the common required ones).
        camera_crop: the rectangle of a kit camera's 480x640 frame that holds the task's
            objects through an episode, ``CAMERA:TOP,LEFT,HEIGHT,WIDTH`` (what the camera
            recipes of ``benchmarks/train_eval.py`` record, ``record --crop``); "" for none.
        pose_static_frames: how many frames of the scene at its start (arms at home, objects
            sampled) the ``camera_pose`` recipe's pose encoder trains on besides the
            episodes' (``train_eval.py --static_frames``); 0 when the episodes' first frames
            serve.
        package: the distribution that registered it (set by the registry).
    """

    name: str
    task: Any
    sampler: Any
    config: str | Path | Mapping[str, Any]
    description: str = ""
    policy: Any = ""
    aliases: tuple[str, ...] = ()
    record: Mapping[str, Any] = field(default_factory=dict)
    stages: Mapping[str, float] = field(default_factory=dict)
    gym_ids: Mapping[str, str] = field(default_factory=dict)
    keys: Mapping[str, Key] = field(default_factory=dict)
    required: tuple[str, ...] = ()
    camera_crop: str = ""
    pose_static_frames: int = 0
    package: str = "trossen_arm_mujoco"

    def task_class(self) -> type:
        """The task's ``Task`` subclass (imported on first use)."""
        return import_path(self.task)

    def sampler_class(self) -> type:
        """The task's ``TaskSampler`` subclass (imported on first use)."""
        return import_path(self.sampler)

    def policy_class(self) -> type:
        """The scripted policy class; a UserError when the task has none."""
        if not self.policy:
            raise UserError(f"task '{self.name}' has no scripted policy")
        return import_path(self.policy)

    def load_config(self, **overrides: Any) -> dict[str, Any]:
        """The task's config, validated, with keyword overrides (an unknown key or an
        invalid value, in the file or an override: a one-line UserError; see
        ``tasks.config_schema``)."""
        from trossen_arm_mujoco.tasks.config import load_entry_config

        return load_entry_config(self, **overrides)

    def problems(self) -> list[str]:
        """What is missing or malformed in this declaration (empty when it is complete)."""
        out = []
        if not isinstance(self.name, str) or not self.name.strip() or " " in self.name:
            out.append(f"name must be a non-empty word, got {self.name!r}")
        for fact in ("task", "sampler", "config"):
            if not getattr(self, fact):
                out.append(f"no {fact} (TaskEntry({fact}=...))")
        if not isinstance(self.config, (str, Path, Mapping)):
            out.append("config must be a config name, a YAML path or a mapping of defaults")
        if self.policy and "episode_len" not in self.record:
            out.append("a scripted policy but no recording defaults (record=record_defaults(N))")
        unknown = sorted(set(self.record) - set(RECORD_KEYS))
        if unknown:
            out.append(
                f"unknown record key(s) {', '.join(unknown)}; valid: {', '.join(RECORD_KEYS)}"
            )
        for stage, level in self.stages.items():
            if not isinstance(level, Real) or not math.isfinite(level):
                out.append(f"stage '{stage}' needs a finite reward level, got {level!r}")
        for env_id, kind in self.gym_ids.items():
            if kind not in GYM_KINDS:
                out.append(f"gym id {env_id} has kind {kind!r}; valid: {', '.join(GYM_KINDS)}")
            if "/" not in env_id or "-v" not in env_id:
                out.append(f"gym id {env_id!r} must look like Namespace/Name-v0")
        if self.camera_crop:
            from trossen_arm_mujoco.sim.camera_crop import parse_crop

            try:
                parse_crop(self.camera_crop)
            except UserError as exc:
                out.append(f"camera_crop: {exc}")
        if not isinstance(self.pose_static_frames, int) or self.pose_static_frames < 0:
            out.append(f"pose_static_frames must be an int >= 0, got {self.pose_static_frames!r}")
        bad_keys = [k for k, v in self.keys.items() if not isinstance(v, Key)]
        if bad_keys:
            out.append(f"config key(s) {', '.join(bad_keys)} must be tasks.config_key.Key values")
        return out
