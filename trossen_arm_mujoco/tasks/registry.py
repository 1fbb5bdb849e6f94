"""Task registry: the ONE way every front door reaches a task.

Every task is one ``TaskEntry`` (``tasks.task_entry``), from the shipped task modules (a
module-level ``TASKS`` tuple) or installed packages (entry-point group
``trossen_arm_mujoco.tasks``), gathered once on import. An installed task that cannot be used
is left out and remembered (:func:`problems`). Classes are imported and configs read only
when a task is used: listing is cheap, a broken config fails only its task's commands.

    >>> from trossen_arm_mujoco.tasks import registry
    >>> from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
    >>> sampler = registry.make_sampler("reach", SamplerSettings(command_mode="ee_delta"))
    >>> task = sampler.sample_task(seed=0)

Docs: docs/writing-a-task.md.
"""

from __future__ import annotations

import dataclasses
import importlib
import re
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

__all__ = [
    "ALIASES",
    "DEFAULT_ARM_TASK",
    "DEFAULT_TASK",
    "ENTRIES",
    "ENTRY_POINT_GROUP",
    "TASKS",
    "RecordDefaults",
    "TaskEntry",
    "arm_names",
    "canonical",
    "kit_names",
    "load",
    "make_sampler",
    "names",
    "problems",
    "record_defaults",
    "scripted_names",
    "sim_task_configs",
    "stages",
]

#: Fields of ``SamplerSettings``: never task config keys.
SETTING_NAMES = frozenset(f.name for f in dataclasses.fields(SamplerSettings))
#: The entry-point group through which installed packages register tasks.
ENTRY_POINT_GROUP = "trossen_arm_mujoco.tasks"
#: The task the command lines and the kit front doors use when none is named.
DEFAULT_TASK = "sim_transfer_cube"
#: The task the gymnasium env classes use when none is named (a single-arm one).
DEFAULT_ARM_TASK = "reach"
_OWN = "trossen_arm_mujoco"
_TASKS_MARKER = re.compile(r"^TASKS\b", re.MULTILINE)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _as_entries(obj: Any) -> list[TaskEntry] | None:
    """``obj`` as a list of entries (a TaskEntry, or an iterable of them); None otherwise."""
    if isinstance(obj, TaskEntry):
        return [obj]
    if isinstance(obj, Iterable) and not isinstance(obj, (str, bytes, dict)):
        items = list(obj)
        if items and all(isinstance(e, TaskEntry) for e in items):
            return items
    return None


def _shipped() -> list[TaskEntry]:
    """Entries of the modules of this package that declare ``TASKS`` (a static look at each
    module's text first, so modules without tasks are not imported)."""
    out: list[TaskEntry] = []
    for path in sorted(Path(__file__).resolve().parent.glob("*.py")):
        if path.stem == "registry" or not _TASKS_MARKER.search(path.read_text(encoding="utf-8")):
            continue
        out.extend(importlib.import_module(f"{__package__}.{path.stem}").TASKS)
    return out


def _installed(broken: dict[str, str]) -> list[TaskEntry]:
    """Entries of the installed packages' entry points; what cannot be used goes to
    ``broken`` (name -> one line naming the package)."""
    out: list[TaskEntry] = []
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        package = ep.dist.name if ep.dist is not None else ep.value.partition(":")[0]
        fix = f"fix it or uninstall it (pip uninstall {package})"
        try:
            obj = ep.load()
        except Exception as exc:  # any failure of a third party's import
            broken[ep.name] = (
                f"task '{ep.name}' of package {package}: its entry point {ep.value} fails to "
                f"import ({_one_line(exc)}); {fix}"
            )
            continue
        entries = _as_entries(obj)
        if entries is None:
            broken[ep.name] = (
                f"task '{ep.name}' of package {package}: its entry point {ep.value} is a "
                f"{type(obj).__name__}, not a TaskEntry (trossen_arm_mujoco.tasks.task_entry); "
                f"{fix}"
            )
            continue
        for entry in entries:
            out.append(dataclasses.replace(entry, package=package))
    return out


def _gather() -> tuple[tuple[TaskEntry, ...], dict[str, str]]:
    """(usable entries, problems: name -> one line), shipped entries first."""
    broken: dict[str, str] = {}
    candidates = [*_shipped(), *_installed(broken)]
    owners: dict[str, list[TaskEntry]] = {}
    for entry in candidates:
        missing = entry.problems()
        if missing:
            broken[str(entry.name)] = (
                f"task '{entry.name}' of package {entry.package}: {'; '.join(missing)}; "
                f"complete its TaskEntry or uninstall the package (pip uninstall {entry.package})"
            )
            continue
        for label in (entry.name, *entry.aliases):
            owners.setdefault(label, []).append(entry)
    for label, entries in owners.items():
        packages = sorted({e.package for e in entries})
        if len(entries) > 1:
            others = [p for p in packages if p != _OWN] or packages
            broken[label] = (
                f"task '{label}' is registered by {len(entries)} entries of package(s) "
                f"{', '.join(packages)}; keep one (pip uninstall {others[-1]}, or rename it)"
            )
    usable = tuple(
        e
        for e in candidates
        if not e.problems() and all(len(owners[x]) == 1 for x in (e.name, *e.aliases))
    )
    return usable, broken


ENTRIES, _BROKEN = _gather()

#: name -> entry, and alias -> entry.
TASKS: dict[str, TaskEntry] = {e.name: e for e in ENTRIES}
ALIASES: dict[str, str] = {alias: e.name for e in ENTRIES for alias in e.aliases}


def problems() -> dict[str, str]:
    """Installed tasks left out: name -> the one-line reason (naming the package)."""
    return dict(_BROKEN)


def names() -> list[str]:
    """Registered task names, sorted (aliases not included)."""
    return sorted(TASKS)


def canonical(name: str) -> str:
    """The registered name of ``name`` (itself, or the task an alias points to); a
    UserError listing the installed names when unknown, or the task's problem when an
    installed package gives it but it cannot be used."""
    name = ALIASES.get(name, name)
    if name not in TASKS:
        if name in _BROKEN:
            raise UserError(_BROKEN[name])
        raise unknown_name_error("task", name, sorted([*TASKS, *ALIASES]), hint=_install_hint())
    return name


def _install_hint() -> str:
    hint = f"tasks of installed packages register through the entry-point group {ENTRY_POINT_GROUP}"
    if _BROKEN:
        hint += "; left out: " + "; ".join(_BROKEN.values())
    return hint


def load(name: str) -> TaskEntry:
    """The entry of a task (or alias); a UserError listing the valid names when unknown."""
    return TASKS[canonical(name)]


def scripted_names() -> list[str]:
    """Tasks that can be recorded with a scripted policy."""
    return sorted(n for n, e in TASKS.items() if e.policy)


def kit_names() -> list[str]:
    """Tasks of the Stationary AI kit (sampler derived from ``BimanualSampler``): the ones
    eval's kit env, a served kit and the LeRobot env plugin take."""
    from trossen_arm_mujoco.tasks.bimanual import BimanualSampler

    return [n for n in names() if issubclass(TASKS[n].sampler_class(), BimanualSampler)]


def arm_names() -> list[str]:
    """Tasks of the single WidowX AI arm (sampler derived from ``tasks.single_arm.
    SingleArmSampler``): the ones eval's single-arm env, a served arm and the LeRobot env
    plugin take in the ``widowxai`` layout."""
    from trossen_arm_mujoco.tasks.single_arm import SingleArmSampler

    return [n for n in names() if issubclass(TASKS[n].sampler_class(), SingleArmSampler)]


def stages(name: str) -> dict[str, float]:
    """Stage name -> the reward that marks it, of task ``name`` (empty when it has none or
    is unknown)."""
    entry = TASKS.get(ALIASES.get(name, name))
    return dict(entry.stages) if entry is not None else {}


def sim_task_configs() -> dict[str, dict[str, Any]]:
    """Recording defaults of every task with a scripted policy (static: no file is read)."""
    return {e.name: dict(e.record) for e in TASKS.values() if e.policy}


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
    """The sampler of a task (it builds the scene), its config overridden by keyword.

    Args:
        name: registered task name or alias.
        settings: how the sampler builds its scene (``tasks.sampler_settings.SamplerSettings``:
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
