"""Task configs: YAML files in ``trossen_arm_mujoco/config/``, overridable by keyword.

A config is a flat dict of plain values (numbers, strings, booleans, lists of numbers), plus
one nested section, ``randomization`` (domain randomization, see ``RANDOMIZATION_SCHEMA``).
The YAML file defines the valid keys: an override with another key is a ``UserError`` listing
the valid ones, and an override must have the same kind of value as the default (a number
for a number, a list of the same length for a list). ``randomization`` overrides are merged
into the file's section kind by kind and validated with it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Real
from pathlib import Path
from typing import Any

import yaml

from trossen_arm_mujoco.errors import UserError, unknown_name_error

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"

#: Config key of the domain-randomization section.
RANDOMIZATION_KEY = "randomization"

# Parameters of each randomization kind: name -> (default, form, low bound, high bound).
# Forms: "bool"; "range" = [low, high] with bound_lo <= low <= high <= bound_hi; "max" = one
# number in [bound_lo, bound_hi]; "names" = a list of model names (checked by the sampler).
_Param = tuple[Any, str, float, float]
RANDOMIZATION_SCHEMA: dict[str, dict[str, _Param]] = {
    "lights": {  # every light of the scene
        "enabled": (True, "bool", 0, 0),
        "direction_deg": (15.0, "max", 0.0, 90.0),  # tilt of the direction, deg
        "diffuse_scale": ([0.6, 1.4], "range", 0.0, 10.0),  # factor on nominal diffuse
        "specular_scale": ([0.5, 1.5], "range", 0.0, 10.0),  # factor on nominal specular
        "ambient": ([0.0, 0.1], "range", 0.0, 1.0),  # added to nominal ambient (grey)
        "colour_jitter": (0.1, "max", 0.0, 1.0),  # per-channel factor in [1-c, 1+c]
    },
    "table": {  # the table's visual geoms: texture (material) choice and tint
        "enabled": (True, "bool", 0, 0),
        "geoms": ([], "names", 0, 0),
        "materials": ([], "names", 0, 0),  # textured materials to choose from; [] = keep
        "rgb_jitter": (0.15, "max", 0.0, 1.0),  # added to each rgb channel, clipped to [0, 1]
    },
    "objects": {  # every geom of the task's free objects
        "enabled": (True, "bool", 0, 0),
        "rgb_jitter": (0.2, "max", 0.0, 1.0),
    },
    "friction": {  # sliding friction of every named collision geom
        "enabled": (True, "bool", 0, 0),
        "scale": ([0.8, 1.2], "range", 0.01, 10.0),
    },
    "object_mass": {  # mass and inertia of each free object
        "enabled": (True, "bool", 0, 0),
        "scale": ([0.8, 1.2], "range", 0.01, 100.0),
    },
    "joint_damping": {  # added to every robot joint's damping, N m s/rad (N s/m fingers)
        "enabled": (True, "bool", 0, 0),
        "range": ([0.0, 0.1], "range", 0.0, 100.0),
    },
    "camera": {  # every camera of the scene, in its parent body's frame
        "enabled": (True, "bool", 0, 0),
        "position": (0.005, "max", 0.0, 0.1),  # m, uniform offset per axis
        "orientation_deg": (1.0, "max", 0.0, 30.0),  # deg, about a random axis
    },
    "joint_noise": {  # initial arm joints (not fingers), rad, uniform
        "enabled": (True, "bool", 0, 0),
        "range": (0.02, "max", 0.0, 0.5),
    },
}


def _check_param(where: str, form: str, lo: float, hi: float, value: Any) -> Any:
    """One randomization parameter validated and converted; a one-line UserError if not."""
    if form == "bool":
        if not isinstance(value, bool):
            raise UserError(f"{where}: expected true/false, got {value!r}")
        return value
    if form == "names":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise UserError(f"{where}: expected a list of names, got {value!r}")
        return list(value)
    numbers = value if form == "range" else [value]
    ok = (
        isinstance(numbers, (list, tuple))
        and len(numbers) == (2 if form == "range" else 1)
        and all(isinstance(v, Real) and not isinstance(v, bool) for v in numbers)
    )
    if ok:
        numbers = [float(v) for v in numbers]
        ok = all(math.isfinite(v) and lo <= v <= hi for v in numbers) and numbers == sorted(numbers)
    if not ok:
        want = (
            f"[low, high] with {lo:g} <= low <= high <= {hi:g}"
            if form == "range"
            else (f"a number in [{lo:g}, {hi:g}]")
        )
        raise UserError(f"{where}: expected {want}, got {value!r}")
    return numbers if form == "range" else numbers[0]


def merge_randomization(name: str, base: Mapping[str, Any], section: Any) -> dict[str, Any]:
    """``base`` (a complete section) updated kind by kind from ``section``, validated.

    Raises:
        UserError: unknown kind or parameter (lists the valid ones), or a value outside its
            form and bounds (see ``RANDOMIZATION_SCHEMA``); one line each.
    """
    where = f"config '{name}', {RANDOMIZATION_KEY}"
    if section is None:
        section = {}
    if not isinstance(section, Mapping):
        raise UserError(f"{where}: expected a mapping of kinds to settings, got {section!r:.60}")
    out = {kind: dict(params) for kind, params in base.items()}
    for kind, params in section.items():
        if kind not in RANDOMIZATION_SCHEMA:
            raise unknown_name_error("randomization kind", str(kind), RANDOMIZATION_SCHEMA,
                                     hint=f"task config '{name}'")  # fmt: skip
        if not isinstance(params, Mapping):
            raise UserError(f"{where}.{kind}: expected a mapping of settings, got {params!r:.60}")
        schema = RANDOMIZATION_SCHEMA[kind]
        for key, value in params.items():
            if key not in schema:
                raise unknown_name_error(f"{kind} randomization setting", str(key), schema,
                                         hint=f"task config '{name}'")  # fmt: skip
            _, form, lo, hi = schema[key]
            out[kind][key] = _check_param(f"{where}.{kind}.{key}", form, lo, hi, value)
    return out


def default_randomization() -> dict[str, Any]:
    """The randomization section with every kind at its defaults (fresh lists)."""
    return {
        kind: {k: (list(d) if isinstance(d, list) else d) for k, (d, *_) in params.items()}
        for kind, params in RANDOMIZATION_SCHEMA.items()
    }


def parse_randomization(name: str, section: Any) -> dict[str, Any]:
    """A YAML ``randomization`` section completed with the defaults and validated."""
    return merge_randomization(name, default_randomization(), section)


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
        if key == RANDOMIZATION_KEY:
            out[key] = merge_randomization(name, defaults[key], value)
        else:
            out[key] = _check_value(name, key, defaults[key], value)
    return out


def load_task_config(name: str, **overrides: Any) -> dict[str, Any]:
    """The config ``config/<name>.yaml`` with keyword overrides applied.

    Raises:
        UserError: unknown config name (lists the valid ones), unknown key (lists the valid
            keys), a value of the wrong kind, or a bad ``randomization`` section (unknown kind
            or parameter, range out of its bounds).
    """
    names = config_names()
    if name not in names:
        raise unknown_name_error("task config", name, names)
    defaults = read_yaml(CONFIG_DIR / f"{name}.yaml")
    defaults[RANDOMIZATION_KEY] = parse_randomization(name, defaults.get(RANDOMIZATION_KEY))
    return merge_overrides(name, defaults, overrides)
