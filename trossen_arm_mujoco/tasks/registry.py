"""Task registry: the ONE way every front door reaches a task.

An entry names everything about a task: its task class (reward, success, description,
observations), its sampler (scenes of both flavours, randomization), its YAML config, its
scripted policy when it has one, and the recording defaults the record CLI starts from.
``SIM_TASK_CONFIGS`` (``constants.py``) is derived from the entries that have a scripted
policy. Classes are named by import path and imported on first use, and YAML configs are
read only when a task is used (``load_config``, ``make_sampler``, ``RecordDefaults[name]``),
so listing is cheap and a broken config fails only the commands that use its task.

    >>> from trossen_arm_mujoco.tasks import registry
    >>> from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
    >>> settings = SamplerSettings(command_mode="ee_delta")
    >>> sampler = registry.make_sampler("reach", settings, success_tolerance=0.03)
    >>> task = sampler.sample_task(seed=0)

Adding a task = one task module (task + sampler), one scripted policy module (optional), one
YAML file in ``config/``, one ``TaskEntry`` below (and a gym id in ``gym/registration.py``;
config keys no task had before: a line each in ``tasks.config_schema.KEYS``).
"""

from __future__ import annotations

import dataclasses
import importlib
from dataclasses import dataclass, field
from typing import Any

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.config import load_task_config
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = [
    "ALIASES",
    "ENTRIES",
    "TASKS",
    "RecordDefaults",
    "TaskEntry",
    "canonical",
    "load",
    "make_sampler",
    "names",
    "scripted_names",
    "sim_task_configs",
]

#: Fields of ``SamplerSettings``: never task config keys.
SETTING_NAMES = frozenset(f.name for f in dataclasses.fields(SamplerSettings))


def _import(path: str) -> Any:
    module, _, attr = path.partition(":")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class TaskEntry:
    """One registered task.

    Attributes:
        name: the task's name (what ``--task_name`` and ``load`` take).
        task, sampler: import paths ``"module:Class"`` of the ``Task`` and ``TaskSampler``.
        config: name of its YAML file in ``config/``.
        description: one line for listings.
        policy: import path of the scripted EE policy (``record``), "" when none.
        aliases: other names accepted for it.
        record: recording defaults (``num_episodes``, ``episode_len``, ``onscreen_render``,
            ``inject_noise``, ``cam_names``) of tasks with a scripted policy.
    """

    name: str
    task: str
    sampler: str
    config: str
    description: str = ""
    policy: str = ""
    aliases: tuple[str, ...] = ()
    record: dict[str, Any] = field(default_factory=dict)

    def task_class(self) -> type:
        """The task's ``Task`` subclass (imported on first use)."""
        return _import(self.task)

    def sampler_class(self) -> type:
        """The task's ``TaskSampler`` subclass (imported on first use)."""
        return _import(self.sampler)

    def policy_class(self) -> type:
        """The scripted policy class; a UserError when the task has none."""
        if not self.policy:
            raise UserError(f"task '{self.name}' has no scripted policy")
        return _import(self.policy)

    def load_config(self, **overrides: Any) -> dict[str, Any]:
        """``config/<config>.yaml``, validated, with keyword overrides (an unknown key or an
        invalid value, in the file or an override: a one-line UserError; see
        ``tasks.config_schema``)."""
        return load_task_config(self.config, **overrides)


def _record_defaults(episode_len: int) -> dict[str, Any]:
    return {
        "num_episodes": 1,
        "episode_len": episode_len,
        "onscreen_render": False,
        "inject_noise": False,
        "cam_names": list(STATIONARY_CAMERAS),
    }


_PKG = "trossen_arm_mujoco.tasks"
_POL = "trossen_arm_mujoco.policies"
ENTRIES: tuple[TaskEntry, ...] = (
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
        "sim_transfer_cube", f"{_PKG}.transfer_cube:TransferCube",
        f"{_PKG}.transfer_cube:TransferCubeSampler", "transfer_cube",
        "Stationary AI: hand a cube from the right arm to the left",
        policy=f"{_POL}.transfer_cube:PickAndTransferPolicy",
        aliases=("transfer_cube",),
        record=_record_defaults(600),
    ),
    TaskEntry(
        "sim_insertion", f"{_PKG}.insertion:InsertionTask",
        f"{_PKG}.insertion:InsertionSampler", "insertion",
        "Stationary AI: insert a peg (right arm) into a socket (left arm) above the table",
        policy=f"{_POL}.insertion:InsertionPolicy",
        aliases=("insertion",),
        record=_record_defaults(400),
    ),
)  # fmt: skip

#: name -> entry, and alias -> entry.
TASKS: dict[str, TaskEntry] = {e.name: e for e in ENTRIES}
ALIASES: dict[str, str] = {alias: e.name for e in ENTRIES for alias in e.aliases}


def names() -> list[str]:
    """Registered task names, sorted (aliases not included)."""
    return sorted(TASKS)


def canonical(name: str) -> str:
    """The registered name of ``name`` (itself, or the task an alias points to)."""
    name = ALIASES.get(name, name)
    if name not in TASKS:
        raise unknown_name_error("task", name, sorted([*TASKS, *ALIASES]))
    return name


def load(name: str) -> TaskEntry:
    """The entry of a task (or alias); a UserError listing the valid names when unknown."""
    return TASKS[canonical(name)]


def scripted_names() -> list[str]:
    """Tasks that can be recorded with a scripted policy."""
    return sorted(n for n, e in TASKS.items() if e.policy)


def sim_task_configs() -> dict[str, dict[str, Any]]:
    """Recording defaults of every task with a scripted policy (static: no file is read)."""
    return {e.name: dict(e.record) for e in ENTRIES if e.policy}


class RecordDefaults(dict):
    """``SIM_TASK_CONFIGS``: task name -> recording defaults (``num_episodes``,
    ``episode_len``, ``onscreen_render``, ``inject_noise``, ``cam_names``), a plain dict of
    ``sim_task_configs()`` except for one thing: ``defaults[name]`` first checks the task's
    YAML config, so a command that looks its task up fails right there, with the config's
    one-line ``UserError``, when that file is broken. Listing (``in``, iteration, ``len``,
    ``keys``, ``get``, ``items``) reads no file."""

    def __init__(self) -> None:
        super().__init__(sim_task_configs())

    def __getitem__(self, name: str) -> dict[str, Any]:
        defaults = super().__getitem__(name)  # KeyError for a task without a policy
        TASKS[name].load_config()
        return defaults


def make_sampler(
    name: str,
    settings: SamplerSettings | None = None,
    *,
    physics: Any = None,
    seed: Any = None,
    **overrides: Any,
):
    """The sampler of a task (it builds the env), its config overridden by keyword.

    Args:
        name: registered task name or alias.
        settings: how the sampler builds its env (``tasks.sampler_settings.SamplerSettings``:
            command mode, cameras, image size, flavour, ``randomize``, looks, floor margin);
            default ``SamplerSettings()``.
        physics, seed: see ``TaskSampler``.
        overrides: task config keys (``tasks.config_schema``), checked like the YAML file.
            A sampler setting given here is a UserError saying to put it in ``settings``.
    """
    misplaced = [k for k in overrides if k in SETTING_NAMES]
    if misplaced:
        raise UserError(
            f"{misplaced[0]} is a sampler setting, not a config key: pass "
            f"make_sampler({name!r}, SamplerSettings({misplaced[0]}=...))"
        )
    entry = load(name)
    config = entry.load_config(**overrides)
    return entry.sampler_class()(config, settings, physics=physics, seed=seed)
