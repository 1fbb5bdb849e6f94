"""Task registry: task name -> (task class, sampler class, default config).

Classes are named by import path and imported on first use, so listing tasks is cheap.

    >>> from trossen_arm_mujoco.tasks import registry
    >>> sampler = registry.make_sampler("reach", command_mode="ee_delta", success_tolerance=0.03)
    >>> task = sampler.sample_task(seed=0)
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.tasks.config import load_task_config
from trossen_arm_mujoco.tasks.sampler import TaskSampler
from trossen_arm_mujoco.tasks.task import Task


def _import(path: str) -> Any:
    module, _, attr = path.partition(":")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class TaskEntry:
    """One registered task: import paths ("module:Class") and its YAML config name."""

    name: str
    task: str
    sampler: str
    config: str
    description: str = ""

    def task_class(self) -> type[Task]:
        return _import(self.task)

    def sampler_class(self) -> type[TaskSampler]:
        return _import(self.sampler)

    def load_config(self, **overrides: Any) -> dict[str, Any]:
        """``config/<config>.yaml`` with keyword overrides (unknown keys -> UserError)."""
        return load_task_config(self.config, **overrides)


_PKG = "trossen_arm_mujoco.tasks"
TASKS: dict[str, TaskEntry] = {
    e.name: e
    for e in (
        TaskEntry(
            "reach", f"{_PKG}.reach:ReachTask", f"{_PKG}.reach:ReachSampler", "reach",
            "wxai: move the tool frame to a target",
        ),
        TaskEntry(
            "push", f"{_PKG}.push:PushTask", f"{_PKG}.push:PushSampler", "push",
            "wxai: push a cube onto a goal on the table",
        ),
        TaskEntry(
            "pick_place", f"{_PKG}.pick_place:PickPlaceTask",
            f"{_PKG}.pick_place:PickPlaceSampler", "pick_place",
            "wxai: bring a cube to a goal on the table or in the air",
        ),
        TaskEntry(
            "transfer_cube", f"{_PKG}.transfer_cube_task:TransferTask",
            f"{_PKG}.transfer_cube_task:TransferCubeSampler", "transfer_cube",
            "Stationary AI: hand a cube from the right arm to the left",
        ),
    )
}  # fmt: skip


def names() -> list[str]:
    """Registered task names, sorted."""
    return sorted(TASKS)


def load(name: str) -> TaskEntry:
    """The entry of a task; a UserError listing the valid names when unknown."""
    if name not in TASKS:
        raise unknown_name_error("task", name, TASKS)
    return TASKS[name]


def make_sampler(
    name: str,
    *,
    command_mode: str = "joint_position",
    camera_names: Sequence[str] = (),
    height: int = 480,
    width: int = 640,
    **overrides: Any,
) -> TaskSampler:
    """The sampler of a task (it builds the env), config overridden by keyword."""
    entry = load(name)
    config = entry.load_config(**overrides)
    return entry.sampler_class()(
        config,
        command_mode=command_mode,
        camera_names=camera_names,
        height=height,
        width=width,
    )
