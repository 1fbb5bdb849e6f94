"""Task configs: YAML files in ``trossen_arm_mujoco/config/``, overridable by keyword.

A config is a flat dict of plain values (numbers, strings, booleans, lists of numbers) plus
one nested section, ``randomization``. Every value is checked by ``tasks.config_schema``;
no key may be given twice; an override may only name a key of the task's file, with a valid
value (a list as long as the file's); ``randomization`` overrides merge kind by kind. Every
problem is a one-line ``UserError``. Configs are read when a task is used
(``TaskEntry.load_config``), never at import: a broken file fails only its task's commands.

Docs: docs/writing-a-task.md; each task's keys: docs/gym/.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.config_key import Source
from trossen_arm_mujoco.tasks.config_schema import check_file_config, check_overrides
from trossen_arm_mujoco.tasks.randomization_schema import (
    check_randomization,
    default_randomization,
)

__all__ = [
    "CONFIG_DIR",
    "config_names",
    "load_entry_config",
    "merge_overrides",
    "merge_randomization",
    "parse_randomization",
    "read_randomization",
    "read_yaml",
]

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def merge_randomization(name: str, base: Mapping[str, Any], section: Any) -> dict[str, Any]:
    """A randomization section updated kind by kind from an override, validated (see
    ``randomization_schema.check_randomization``).

    Args:
        name: the task config's name, for errors.
        base: a complete ``randomization`` section.
        section: the override (a mapping of kinds).
    """
    return check_randomization(Source.overrides(name), base, section)


def parse_randomization(name: str, section: Any) -> dict[str, Any]:
    """A ``randomization`` section of task config ``name`` completed with the defaults and
    validated."""
    return check_randomization(Source(f"task config '{name}'"), default_randomization(), section)


# -- reading YAML --------------------------------------------------------------------------------
class DuplicateKeyError(yaml.YAMLError):
    """A key given twice in one YAML mapping: its dotted ``path`` and 1-based ``lines``."""

    def __init__(self, path: str, first: int, again: int):
        super().__init__(f"key {path} given twice (lines {first} and {again})")
        self.path, self.first, self.again = path, first, again


def _check_duplicates(node: yaml.Node, path: str = "") -> None:
    """Every mapping under ``node`` with each (scalar) key at most once; DuplicateKeyError
    with the key's dotted path otherwise."""
    if isinstance(node, yaml.MappingNode):
        seen: dict[str, int] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag.endswith(":merge"):
                continue  # merge keys (<<) may be overridden; other keys: SafeLoader's rules
            key, line = key_node.value, key_node.start_mark.line + 1
            dotted = f"{path}.{key}" if path else key
            if key in seen:
                raise DuplicateKeyError(dotted, seen[key], line)
            seen[key] = line
            _check_duplicates(value_node, dotted)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _check_duplicates(item, f"{path}[{i}]")


class StrictLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses a key given twice in one mapping (PyYAML keeps the
    last one silently) and reads ``1e-3`` (exponent, no dot) as a number, as YAML 1.2 does."""

    def get_single_data(self) -> Any:
        node = self.get_single_node()
        if node is None:
            return None
        _check_duplicates(node)
        return self.construct_document(node)


StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def parse_yaml(text: str, origin: str) -> Any:
    """YAML ``text`` read with ``StrictLoader``; a one-line UserError naming ``origin`` (the
    file), the line and the problem when it cannot be read."""
    try:
        return yaml.load(text, Loader=StrictLoader)  # noqa: S506  (a SafeLoader)
    except DuplicateKeyError as exc:
        raise UserError(
            f"{origin}, key {exc.path}: given twice (lines {exc.first} and {exc.again}); keep one"
        ) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).strip().splitlines()[0]
        raise UserError(f"{origin}: cannot parse YAML{line}: {problem}") from None


def config_names() -> list[str]:
    """Names of the shipped task configs (file stems of ``config/*.yaml``); no file is read."""
    return sorted(p.stem for p in CONFIG_DIR.glob("*.yaml"))


def read_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML mapping from a file (keys given twice refused); one-line UserErrors for
    missing, unreadable or malformed files."""
    p = Path(path)
    if not p.is_file():
        raise UserError(f"config file not found: {p}")
    origin = Source.file(p).origin
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{origin}: cannot read it: {exc}") from None
    data = parse_yaml(text, origin)
    if not isinstance(data, dict):
        raise UserError(
            f"{origin}: expected a mapping of keys to values, got {type(data).__name__}"
        )
    return data


def read_randomization(path: str | Path) -> dict[str, Any]:
    """The ``randomization`` section of a YAML file: the file's ``randomization`` key, or
    the whole file when it has none (kinds at the top level). Checked against the schema
    (``tasks.randomization_schema``): an unknown kind or setting, or a value out of its
    bounds, is a one-line UserError naming the file."""
    from trossen_arm_mujoco.tasks.randomization_schema import (
        RANDOMIZATION_KEY,
        check_randomization,
        default_randomization,
    )

    data = read_yaml(path)
    section = data.get(RANDOMIZATION_KEY, data) if RANDOMIZATION_KEY in data else data
    check_randomization(Source.file(Path(path)), default_randomization(), section)
    return dict(section)


def merge_overrides(
    name: str,
    defaults: Mapping[str, Any],
    overrides: Mapping[str, Any],
    keys: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """``defaults`` updated with ``overrides``; unknown keys and invalid values raise.

    Args:
        name: the task's name, for errors.
        defaults: the checked config.
        overrides: keyword overrides (config key -> value).
        keys: the task's own keys (its ``TaskEntry.keys``); None: the shared ones only.

    Raises:
        UserError: an unknown key or an invalid value (one line).
    """
    return check_overrides(name, defaults, overrides, keys)


def load_entry_config(entry: Any, **overrides: Any) -> dict[str, Any]:
    """The config of a ``TaskEntry``, validated with its own ``keys`` and ``required``, with
    keyword overrides applied. ``entry.config``: a shipped config's name (``config/<name>.yaml``),
    the path of a YAML file, or a mapping of defaults (checked like a file)."""
    config, keys, required = entry.config, dict(entry.keys), tuple(entry.required)
    if isinstance(config, Mapping):
        source = Source(f"config of task '{entry.name}' (package {entry.package})")
        name, data = entry.name, config
    elif isinstance(config, Path) or str(config).endswith((".yaml", ".yml")):
        path = Path(config)
        source, name, data = Source.file(path), path.stem, read_yaml(path)
    else:
        names = config_names()
        if config not in names:
            raise unknown_name_error("task config", str(config), names)
        path = CONFIG_DIR / f"{config}.yaml"
        source, name, data = Source.file(path), str(config), read_yaml(path)
    defaults = check_file_config(name, source, data, keys, required)
    return merge_overrides(name, defaults, overrides, keys)
