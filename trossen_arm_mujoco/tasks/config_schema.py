"""The one validation layer of task configs: every key of every YAML file and every keyword
override (``TaskEntry.load_config``, ``registry.make_sampler``, the gym env's kwargs).

A value is checked against its ``Key`` (``config_key``): its kind, its range (NaN and inf
never valid), and ``X_low <= X_high`` on every axis for each pair (``range_pairs``). A file
may hold only the shared keys (``KEYS``) and its task's own (``TaskEntry.keys``), and must
hold ``REQUIRED`` and ``TaskEntry.required``. Every problem is one ``UserError`` line naming
the file (or the task and keyword argument), the key and what is valid. Reading the files is
``tasks.config``'s; the ``randomization`` section is ``randomization_schema``'s.

Docs: docs/writing-a-task.md; each task's keys: docs/gym/.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from numbers import Integral
from typing import Any

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.config_key import (
    Key,
    Source,
    fmt_number,
    is_real,
    number,
    positive,
    show,
    vector,
)
from trossen_arm_mujoco.tasks.randomization_schema import (
    RANDOMIZATION_KEY,
    check_randomization,
    default_randomization,
)

__all__ = [
    "KEYS",
    "REQUIRED",
    "check_file_config",
    "check_overrides",
    "check_ranges",
    "range_pairs",
]

_BOOL, _PATH = Key("bool"), Key("str")
_num, _pos, _vec = number, positive, vector

#: The keys every task config may have (besides ``randomization`` and its task's own
#: ``TaskEntry.keys``), and what they accept.
KEYS: dict[str, Key] = {
    # model and timing
    "scene": _PATH,  # MJCF path relative to the assets folder
    "ee_scene": _PATH,  # end-effector (mocap) flavour of a bimanual task
    "policy_dt": _pos(1.0, "s"),
    "ctrl_dt": _pos(1.0, "s"),
    "sim_dt": _pos(0.1, "s"),
    "max_episode_steps": Key("int", 1, 10_000_000),
    "terminate_on_success": _BOOL,
    # actions and the safety floor
    "ee_delta_limit": _pos(0.5, "m"),
    "joint_rel_limit": _pos(math.pi, "rad"),
    "hold_orientation": _BOOL,
    "table_height": _num(-1.0, 2.0, "m"),
    "safety_margin": _num(0.0, 0.5, "m"),
    # observation bounds
    "workspace_low": _vec(3),
    "workspace_high": _vec(3),
    "max_joint_velocity": _pos(1000.0, "rad/s"),
    "max_object_velocity": _pos(1000.0, "m/s"),
}

#: Keys every task config must have (every task reads them unconditionally); a task's own
#: required keys are its ``TaskEntry.required``.
REQUIRED: tuple[str, ...] = (
    "scene",
    "policy_dt",
    "ctrl_dt",
    "max_episode_steps",
    "ee_delta_limit",
    "joint_rel_limit",
    "table_height",
    "safety_margin",
    "workspace_low",
    "workspace_high",
    "max_joint_velocity",
)


def range_pairs(keys: Any) -> list[tuple[str, str]]:
    """The ``(X_low, X_high)`` pairs among ``keys``: low <= high on every axis."""
    keys = set(keys)
    return [
        (k, k[: -len("_low")] + "_high")
        for k in sorted(keys)
        if k.endswith("_low") and k[: -len("_low")] + "_high" in keys
    ]


# -- whole configs ----------------------------------------------------------------------------
def _check_fallback(where: str, default: Any, value: Any) -> Any:
    """A key outside ``KEYS`` (a config built in code): ``value`` of the kind of ``default``."""
    if isinstance(default, bool):
        return Key("bool").check(where, value)
    if is_real(default):
        return Key("int" if isinstance(default, Integral) else "number").check(where, value)
    if isinstance(default, (list, tuple)) and all(is_real(v) for v in default):
        return Key("vector").check(where, value, length=len(default))
    if isinstance(default, str):
        return Key("str").check(where, value)
    return value


def check_ranges(config: Mapping[str, Any], source: Source, changed: Any = None) -> None:
    """Every ``RANGE_PAIRS`` pair of ``config``: same length, low <= high on every axis.

    Args:
        config: the config.
        source: where the values come from, for errors.
        changed: keys of an override: a pair is blamed on ``source`` only when one of its
            keys is among them; None: always.
    """
    for lo_key, hi_key in range_pairs(config):
        if changed is not None and lo_key not in changed and hi_key not in changed:
            continue
        low, high = list(config[lo_key]), list(config[hi_key])
        where = source.where(f"{lo_key}/{hi_key}")
        if len(low) != len(high):
            raise UserError(
                f"{where}: expected lists of the same length, got {len(low)} and {len(high)}"
            )
        for axis, (a, b) in enumerate(zip(low, high)):
            if a > b:
                raise UserError(
                    f"{where}: expected {lo_key} <= {hi_key} on every axis, got {fmt_number(a)} > "
                    f"{fmt_number(b)} on axis {axis} (low {show(low)}, high {show(high)})"
                )


def check_file_config(
    name: str,
    source: Source,
    data: Mapping[str, Any],
    keys: Mapping[str, Key] | None = None,
    required: tuple[str, ...] = (),
) -> dict[str, Any]:
    """A config file's mapping validated and converted: known keys only, the required ones
    present, every value valid, every range pair ordered; ``randomization`` completed with
    the defaults.

    Args:
        name: the task's name.
        source: the file, for errors.
        data: the file's mapping.
        keys: the task's own keys (its ``TaskEntry.keys``), besides ``KEYS`` and
            ``randomization``.
        required: keys the task requires, besides ``REQUIRED``.
    """
    table = {**KEYS, **(keys or {})}
    valid = [*table, RANDOMIZATION_KEY]
    for key in data:
        if not isinstance(key, str) or key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            keys = ", ".join(sorted(valid))
            raise UserError(f"{source.where(str(key))}: unknown key{hint}; valid keys: {keys}")
    missing = [k for k in (*REQUIRED, *required) if k not in data]
    if missing:
        raise UserError(
            f"{source.origin}: missing {source.label}(s) {', '.join(missing)}; add them "
            "(the shipped config/*.yaml show every key)"
        )
    out: dict[str, Any] = {}
    for key, value in data.items():
        if key != RANDOMIZATION_KEY:
            out[key] = table[key].check(source.where(key), value)
    out[RANDOMIZATION_KEY] = check_randomization(
        source, default_randomization(), data.get(RANDOMIZATION_KEY)
    )
    check_ranges(out, source)
    return out


def check_overrides(
    name: str,
    defaults: Mapping[str, Any],
    overrides: Mapping[str, Any],
    keys: Mapping[str, Key] | None = None,
) -> dict[str, Any]:
    """A checked config updated with keyword overrides, validated: only the defaults' keys,
    each value valid (a vector as long as the default's), range pairs still ordered.

    Args:
        name: the task's name, for errors.
        defaults: the checked config.
        overrides: keyword overrides (config key -> value).
        keys: the task's own keys (its ``TaskEntry.keys``).
    """
    source = Source.overrides(name)
    table = {**KEYS, **(keys or {})}
    out = dict(defaults)
    for key, value in overrides.items():
        if key not in defaults:
            raise unknown_name_error("config key", key, defaults, hint=source.origin)
        where = source.where(key)
        default = defaults[key]
        if key == RANDOMIZATION_KEY:
            out[key] = check_randomization(source, default, value)
        elif key in table:
            vector = table[key].kind == "vector"
            out[key] = table[key].check(where, value, length=len(default) if vector else None)
        else:
            out[key] = _check_fallback(where, default, value)
    check_ranges(out, source, changed=overrides)
    return out
