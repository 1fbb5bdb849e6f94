"""The one validation layer of task configs: every key of every YAML file and every keyword
override (``load_task_config``, ``registry.make_sampler``, the gym env's kwargs).

A value is checked against its ``Key``: its kind (number, whole number, true/false, string,
one of a few names, a list of numbers of a given length), its range (NaN and inf are never
valid), and, for the ``*_low`` / ``*_high`` pairs of ``RANGE_PAIRS``, low <= high on every
axis. A file may hold only keys of ``KEYS`` and must hold those of ``REQUIRED`` (a task with
keys of its own adds a line each there). Every problem is one ``UserError`` line naming the
file (or the task and the keyword argument), the key and what is valid. (Reading the files,
keys given twice included, is ``tasks.config``'s.)

The ``randomization`` section has its own table, ``RANDOMIZATION_SCHEMA``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error

INF = math.inf
#: Config key of the domain-randomization section.
RANDOMIZATION_KEY = "randomization"


# -- where values come from --------------------------------------------------------------------
@dataclass(frozen=True)
class Source:
    """Where config values come from, for error messages.

    Attributes:
        origin: ``config file <path>`` or ``task config '<name>'``.
        label: what a key is called there: ``key`` or ``keyword argument``.
    """

    origin: str
    label: str = "key"

    @classmethod
    def file(cls, path: Any) -> Source:
        return cls(f"config file {path}", "key")

    @classmethod
    def overrides(cls, name: str) -> Source:
        return cls(f"task config '{name}'", "keyword argument")

    def where(self, key: str) -> str:
        return f"{self.origin}, {self.label} {key}"


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _real(value: Any) -> bool:
    """A real number (Python or numpy), not a bool."""
    return isinstance(value, Real) and not isinstance(value, (bool, np.bool_))


def _fmt(x: float) -> str:
    """``x`` short: ``0.5``, ``1e-05``, ``10000000`` (whole numbers in full)."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


# -- one key ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Key:
    """What one config key accepts.

    Attributes:
        kind: ``number`` | ``int`` (a whole number) | ``bool`` | ``str`` (non-empty) |
            ``choice`` (one of ``choices``) | ``vector`` (a list of numbers, ``lengths``).
        low, high: bounds of a number (or of every entry of a vector); NaN and inf never pass.
        open_low: ``low`` itself excluded (``> low``).
        lengths: the lengths a vector may have.
        choices: the names a ``choice`` may be.
        unit: shown after the range (m, rad, s, ...).
    """

    kind: str
    low: float = -INF
    high: float = INF
    open_low: bool = False
    lengths: tuple[int, ...] = ()
    choices: tuple[str, ...] = ()
    unit: str = ""

    def _interval(self) -> str:
        """``in (0, 1] m``, ``>= 0``, ... ("" when unbounded)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.low == -INF and self.high == INF:
            return ""
        if self.high == INF:
            return f"{'>' if self.open_low else '>='} {_fmt(self.low)}{unit}"
        if self.low == -INF:
            return f"<= {_fmt(self.high)}{unit}"
        return f"in {'(' if self.open_low else '['}{_fmt(self.low)}, {_fmt(self.high)}]{unit}"

    def describe(self) -> str:
        """What is valid, in words: ``a number in (0, 1] m``."""
        if self.kind == "bool":
            return "true/false"
        if self.kind == "str":
            return "a non-empty string"
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        interval = self._interval()
        if self.kind in ("int", "number"):
            noun = "a whole number" if self.kind == "int" else "a number"
            return f"{noun} {interval}" if interval else f"a finite {noun[2:]}"
        sizes = " or ".join(str(n) for n in self.lengths) or "some"
        return f"a list of {sizes} numbers, each {interval or 'finite'}"

    def _in_range(self, value: Any) -> bool:
        try:
            x = float(value)
        except (OverflowError, TypeError, ValueError):
            return False
        if not math.isfinite(x):
            return False
        above = x > self.low if self.open_low else x >= self.low
        return above and x <= self.high

    def check(self, where: str, value: Any, length: int | None = None) -> Any:
        """``value`` converted (int, float, bool, str, list of floats); a one-line UserError
        ``<where>: expected <what is valid>, got <value>`` when it is not valid. ``length``:
        the one length a vector must have (an override of a file's vector)."""
        bad = UserError(f"{where}: expected {self.describe()}, got {_show(value)}")
        if self.kind == "bool":
            if isinstance(value, (bool, np.bool_)):
                return bool(value)
            raise bad
        if self.kind in ("str", "choice"):
            if not isinstance(value, str) or not value.strip():
                raise bad
            if self.kind == "choice" and value not in self.choices:
                raise bad
            return value
        if self.kind in ("number", "int"):
            if not _real(value) or not self._in_range(value):
                raise bad
            x = float(value)
            if self.kind == "int":
                if not isinstance(value, Integral) and x != int(x):
                    raise bad
                return int(x)
            return x
        # vector
        if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
            raise bad
        seq = list(value) if getattr(value, "ndim", 1) == 1 else None
        lengths = (length,) if length is not None else self.lengths
        if seq is None or (lengths and len(seq) not in lengths):
            if length is not None and seq is not None:
                raise UserError(
                    f"{where}: expected a list of {length} numbers (as in the task's file), "
                    f"got {_show(value)}"
                )
            raise bad
        if not all(_real(v) and self._in_range(v) for v in seq):
            raise bad
        return [float(v) for v in seq]


def _num(low: float = -INF, high: float = INF, unit: str = "", open_low: bool = False) -> Key:
    return Key("number", low, high, open_low, unit=unit)


def _pos(high: float = INF, unit: str = "") -> Key:
    return Key("number", 0.0, high, True, unit=unit)


def _vec(*lengths: int, low: float = -10.0, high: float = 10.0, unit: str = "m") -> Key:
    return Key("vector", low, high, lengths=lengths, unit=unit)


_BOOL, _PATH = Key("bool"), Key("str")
_COEF = _num(0.0, unit="")  # reward weights: finite, >= 0

#: Every key a task config may have (besides ``randomization``), and what it accepts.
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
    # episode start
    "init_arm_qpos": _vec(6, low=-math.tau, high=math.tau, unit="rad"),
    "init_joint_noise": _num(0.0, 1.0, "rad"),
    "init_gripper": _num(0.0, 0.044, "m"),  # finger travel: closed .. open (robot.layout)
    # spawn and goal regions
    "target_low": _vec(3),
    "target_high": _vec(3),
    "cube_low": _vec(2),
    "cube_high": _vec(2),
    "goal_low": _vec(2, 3),
    "goal_high": _vec(2, 3),
    "air_goal_probability": _num(0.0, 1.0),
    "min_goal_distance": _num(0.0, 10.0, "m"),
    # success and rewards
    "success_tolerance": _pos(1.0, "m"),
    "goal_reward_type": Key("choice", choices=("sparse", "dense")),
    "reach_coef": _COEF,
    "distance_coef": _COEF,
    "lift_bonus": _COEF,
    "success_bonus": _COEF,
    "lift_height": _num(0.0, 1.0, "m"),
}

#: ``*_low`` / ``*_high`` pairs: low <= high on every axis.
RANGE_PAIRS: tuple[tuple[str, str], ...] = (
    ("workspace_low", "workspace_high"),
    ("target_low", "target_high"),
    ("cube_low", "cube_high"),
    ("goal_low", "goal_high"),
)

#: Keys every task config must have (its task reads them unconditionally), by config name;
#: ``"*"`` for every config.
REQUIRED: dict[str, tuple[str, ...]] = {
    "*": ("scene", "policy_dt", "ctrl_dt", "max_episode_steps", "ee_delta_limit",
          "joint_rel_limit", "table_height", "safety_margin", "workspace_low", "workspace_high",
          "max_joint_velocity"),
    "reach": ("init_arm_qpos", "target_low", "target_high", "success_tolerance",
              "goal_reward_type"),
    "push": ("init_arm_qpos", "cube_low", "cube_high", "goal_low", "goal_high",
             "min_goal_distance", "success_tolerance", "reach_coef", "goal_reward_type",
             "max_object_velocity"),
    "pick_place": ("init_arm_qpos", "cube_low", "cube_high", "goal_low", "goal_high",
                   "air_goal_probability", "min_goal_distance", "success_tolerance",
                   "reach_coef", "lift_bonus", "lift_height", "goal_reward_type",
                   "max_object_velocity"),
    "transfer_cube": ("ee_scene", "max_object_velocity"),
    "insertion": ("ee_scene", "max_object_velocity"),
}  # fmt: skip


# -- the randomization section ---------------------------------------------------------------
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
            raise UserError(f"{where}: expected a list of names, got {_show(value)}")
        return list(value)
    numbers = value if form == "range" else [value]
    ok = (
        isinstance(numbers, (list, tuple))
        and len(numbers) == (2 if form == "range" else 1)
        and all(_real(v) for v in numbers)
    )
    if ok:
        bounds = Key("number", lo, hi)
        ok = all(bounds._in_range(v) for v in numbers)
    if ok:
        numbers = [float(v) for v in numbers]
        ok = numbers == sorted(numbers)
    if not ok:
        want = (
            f"[low, high] with {lo:g} <= low <= high <= {hi:g}"
            if form == "range"
            else (f"a number in [{lo:g}, {hi:g}]")
        )
        raise UserError(f"{where}: expected {want}, got {_show(value)}")
    return numbers if form == "range" else numbers[0]


def default_randomization() -> dict[str, Any]:
    """The randomization section with every kind at its defaults (fresh lists)."""
    return {
        kind: {k: (list(d) if isinstance(d, list) else d) for k, (d, *_) in params.items()}
        for kind, params in RANDOMIZATION_SCHEMA.items()
    }


def check_randomization(source: Source, base: Mapping[str, Any], section: Any) -> dict[str, Any]:
    """``base`` (a complete section) updated kind by kind from ``section``, validated.

    Raises:
        UserError: unknown kind or parameter (lists the valid ones), or a value outside its
            form and bounds (see ``RANDOMIZATION_SCHEMA``); one line each.
    """
    where = source.where(RANDOMIZATION_KEY)
    if section is None:
        section = {}
    if not isinstance(section, Mapping):
        raise UserError(f"{where}: expected a mapping of kinds to settings, got {_show(section)}")
    out = {kind: dict(params) for kind, params in base.items()}
    for kind, params in section.items():
        if kind not in RANDOMIZATION_SCHEMA:
            raise unknown_name_error("randomization kind", str(kind), RANDOMIZATION_SCHEMA,
                                     hint=source.origin)  # fmt: skip
        if not isinstance(params, Mapping):
            raise UserError(f"{where}.{kind}: expected a mapping of settings, got {_show(params)}")
        schema = RANDOMIZATION_SCHEMA[kind]
        for key, value in params.items():
            if key not in schema:
                raise unknown_name_error(f"{kind} randomization setting", str(key), schema,
                                         hint=source.origin)  # fmt: skip
            _, form, lo, hi = schema[key]
            out[kind][key] = _check_param(f"{where}.{kind}.{key}", form, lo, hi, value)
    return out


# -- whole configs ----------------------------------------------------------------------------
def _check_fallback(where: str, default: Any, value: Any) -> Any:
    """A key outside ``KEYS`` (a config built in code): ``value`` of the kind of ``default``."""
    if isinstance(default, bool):
        return Key("bool").check(where, value)
    if _real(default):
        return Key("int" if isinstance(default, Integral) else "number").check(where, value)
    if isinstance(default, (list, tuple)) and all(_real(v) for v in default):
        return Key("vector").check(where, value, length=len(default))
    if isinstance(default, str):
        return Key("str").check(where, value)
    return value


def check_ranges(config: Mapping[str, Any], source: Source, changed: Any = None) -> None:
    """Every ``RANGE_PAIRS`` pair of ``config``: same length, low <= high on every axis.
    ``changed`` (keys of an override): the pair is blamed on ``source`` only when one of its
    keys is among them (``None``: always)."""
    for lo_key, hi_key in RANGE_PAIRS:
        if lo_key not in config or hi_key not in config:
            continue
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
                    f"{where}: expected {lo_key} <= {hi_key} on every axis, got {_fmt(a)} > "
                    f"{_fmt(b)} on axis {axis} (low {_show(low)}, high {_show(high)})"
                )


def check_file_config(name: str, source: Source, data: Mapping[str, Any]) -> dict[str, Any]:
    """A config file's mapping validated and converted: known keys only (``KEYS`` and
    ``randomization``), the required ones of ``REQUIRED`` present, every value valid, every
    range pair ordered; ``randomization`` completed with the defaults."""
    valid = [*KEYS, RANDOMIZATION_KEY]
    for key in data:
        if not isinstance(key, str) or key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            keys = ", ".join(sorted(valid))
            raise UserError(f"{source.where(str(key))}: unknown key{hint}; valid keys: {keys}")
    missing = [k for k in (*REQUIRED["*"], *REQUIRED.get(name, ())) if k not in data]
    if missing:
        raise UserError(
            f"{source.origin}: missing {source.label}(s) {', '.join(missing)}; add them "
            "(the shipped config/*.yaml show every key)"
        )
    out: dict[str, Any] = {}
    for key, value in data.items():
        if key != RANDOMIZATION_KEY:
            out[key] = KEYS[key].check(source.where(key), value)
    out[RANDOMIZATION_KEY] = check_randomization(
        source, default_randomization(), data.get(RANDOMIZATION_KEY)
    )
    check_ranges(out, source)
    return out


def check_overrides(
    name: str, defaults: Mapping[str, Any], overrides: Mapping[str, Any]
) -> dict[str, Any]:
    """``defaults`` (a checked config) updated with keyword ``overrides``, validated: only
    the defaults' keys, each value valid (a vector as long as the default's), range pairs
    still ordered."""
    source = Source.overrides(name)
    out = dict(defaults)
    for key, value in overrides.items():
        if key not in defaults:
            raise unknown_name_error("config key", key, defaults, hint=source.origin)
        where = source.where(key)
        default = defaults[key]
        if key == RANDOMIZATION_KEY:
            out[key] = check_randomization(source, default, value)
        elif key in KEYS:
            vector = KEYS[key].kind == "vector"
            out[key] = KEYS[key].check(where, value, length=len(default) if vector else None)
        else:
            out[key] = _check_fallback(where, default, value)
    check_ranges(out, source, changed=overrides)
    return out
