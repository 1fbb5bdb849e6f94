"""The ``randomization`` section of a task config: its kinds, their parameters, defaults and
bounds (``RANDOMIZATION_SCHEMA``), and its validation (``check_randomization``).

Each kind (lights, table, objects, friction, object_mass, joint_damping, camera, joint_noise)
has parameters of one form: ``bool``; ``range`` = [low, high] with bound_lo <= low <= high <=
bound_hi; ``max`` = one number in [bound_lo, bound_hi]; ``names`` = a list of model names
(checked by the sampler against its scene). A section given in a file or an override updates
a complete one kind by kind; unknown kinds and parameters are refused with the valid ones.
What the kinds do to a scene is ``tasks.randomization``'s.

Docs: docs/concepts/randomization.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.config_key import Key, Source, is_real, show

__all__ = [
    "RANDOMIZATION_KEY",
    "RANDOMIZATION_SCHEMA",
    "check_randomization",
    "default_randomization",
]

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
        return Key("bool").check(where, value)
    if form == "names":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise UserError(f"{where}: expected a list of names, got {show(value)}")
        return list(value)
    numbers = value if form == "range" else [value]
    ok = (
        isinstance(numbers, (list, tuple))
        and len(numbers) == (2 if form == "range" else 1)
        and all(is_real(v) for v in numbers)
    )
    if ok:
        bounds = Key("number", lo, hi)
        ok = all(bounds.in_range(v) for v in numbers)
    if ok:
        numbers = [float(v) for v in numbers]
        ok = numbers == sorted(numbers)
    if not ok:
        want = (
            f"[low, high] with {lo:g} <= low <= high <= {hi:g}"
            if form == "range"
            else (f"a number in [{lo:g}, {hi:g}]")
        )
        raise UserError(f"{where}: expected {want}, got {show(value)}")
    return numbers if form == "range" else numbers[0]


def default_randomization() -> dict[str, Any]:
    """The randomization section with every kind at its defaults (fresh lists)."""
    return {
        kind: {k: (list(d) if isinstance(d, list) else d) for k, (d, *_) in params.items()}
        for kind, params in RANDOMIZATION_SCHEMA.items()
    }


def check_randomization(source: Source, base: Mapping[str, Any], section: Any) -> dict[str, Any]:
    """``base`` (a complete section) updated kind by kind from ``section``, validated.

    Args:
        source: where ``section`` comes from, for errors.
        base: a complete ``randomization`` section.
        section: the override (kind -> parameters).

    Raises:
        UserError: unknown kind or parameter (lists the valid ones), or a value outside its
            form and bounds (see ``RANDOMIZATION_SCHEMA``); one line each.
    """
    where = source.where(RANDOMIZATION_KEY)
    if section is None:
        section = {}
    if not isinstance(section, Mapping):
        raise UserError(f"{where}: expected a mapping of kinds to settings, got {show(section)}")
    out = {kind: dict(params) for kind, params in base.items()}
    for kind, params in section.items():
        if kind not in RANDOMIZATION_SCHEMA:
            raise unknown_name_error(
                "randomization kind", str(kind), RANDOMIZATION_SCHEMA, hint=source.origin
            )
        if not isinstance(params, Mapping):
            raise UserError(f"{where}.{kind}: expected a mapping of settings, got {show(params)}")
        schema = RANDOMIZATION_SCHEMA[kind]
        for key, value in params.items():
            if key not in schema:
                raise unknown_name_error(
                    f"{kind} randomization setting", str(key), schema, hint=source.origin
                )
            _, form, lo, hi = schema[key]
            out[kind][key] = _check_param(f"{where}.{kind}.{key}", form, lo, hi, value)
    return out
