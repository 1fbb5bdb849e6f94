"""Task configs: YAML files in ``trossen_arm_mujoco/config/``, overridable by keyword.

A config is a flat dict of plain values (numbers, strings, booleans, lists of numbers). The
YAML file defines the valid keys: an override with another key is a ``UserError`` listing
the valid ones, and an override must have the same kind of value as the default (a number
for a number, a list of the same length for a list).
"""

from __future__ import annotations

from collections.abc import Mapping
from numbers import Real
from pathlib import Path
from typing import Any

import yaml

from trossen_arm_mujoco.errors import UserError, unknown_name_error

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def config_names() -> list[str]:
    """Names of the shipped task configs (file stems of ``config/*.yaml``)."""
    return sorted(p.stem for p in CONFIG_DIR.glob("*.yaml"))


def read_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML mapping from a file; one-line UserErrors for missing or malformed files."""
    p = Path(path)
    if not p.is_file():
        raise UserError(f"config file not found: {p}")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        first = str(exc).strip().splitlines()[0]
        raise UserError(f"cannot parse config {p}: {first}") from exc
    if not isinstance(data, dict):
        raise UserError(f"config {p} must be a mapping of keys to values")
    return data


def _check_value(name: str, key: str, default: Any, value: Any) -> Any:
    """``value`` converted to the kind of ``default``; a UserError when it does not fit."""
    where = f"config '{name}', key '{key}'"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise UserError(f"{where}: expected true/false, got {value!r}")
        return value
    if isinstance(default, Real):
        if isinstance(value, bool) or not isinstance(value, Real):
            raise UserError(f"{where}: expected a number, got {value!r}")
        if isinstance(default, int):
            if value != int(value):
                raise UserError(f"{where}: expected a whole number, got {value!r}")
            return int(value)
        return float(value)
    if isinstance(default, list):
        if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
            raise UserError(f"{where}: expected a list of {len(default)} values, got {value!r}")
        seq = list(value)
        if len(seq) != len(default):
            raise UserError(f"{where}: expected {len(default)} values, got {len(seq)}")
        return [float(v) for v in seq]
    if isinstance(default, str):
        if not isinstance(value, str):
            raise UserError(f"{where}: expected a string, got {value!r}")
        return value
    return value


def merge_overrides(
    name: str, defaults: Mapping[str, Any], overrides: Mapping[str, Any]
) -> dict[str, Any]:
    """``defaults`` updated with ``overrides``; unknown keys and ill-typed values raise."""
    out = dict(defaults)
    for key, value in overrides.items():
        if key not in defaults:
            raise unknown_name_error("config key", key, defaults, hint=f"task config '{name}'")
        out[key] = _check_value(name, key, defaults[key], value)
    return out


def load_task_config(name: str, **overrides: Any) -> dict[str, Any]:
    """The config ``config/<name>.yaml`` with keyword overrides applied.

    Raises:
        UserError: unknown config name (lists the valid ones), unknown key (lists the valid
            keys) or a value of the wrong kind.
    """
    names = config_names()
    if name not in names:
        raise unknown_name_error("task config", name, names)
    defaults = read_yaml(CONFIG_DIR / f"{name}.yaml")
    return merge_overrides(name, defaults, overrides)
