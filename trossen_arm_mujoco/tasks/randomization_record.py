"""A randomization record: what one episode's domain randomization set, as plain data.

A record is a JSON-able dict of every sampled value, in absolute units, keyed by model names
(``tasks.randomization.SceneRandomizer`` samples them): ``version``, ``seed``, and per
enabled kind ``lights``, ``table``, ``objects`` (rgba), ``friction``, ``object_mass`` (kg,
kg m^2), ``joint_damping``, ``camera`` (pos m, quat wxyz in the parent body frame) and
``joint_noise`` (rad). :func:`apply_randomization` writes a record into any model with those
names (e.g. to re-render a recorded episode); ``record_to_json`` / ``record_from_json`` store
it; ``seed`` rebuilds the generator it was drawn from (``generator_from_seed``).

Docs: docs/concepts/randomization.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_SCHEMA

__all__ = [
    "KINDS",
    "RECORD_VERSION",
    "NameIds",
    "apply_randomization",
    "generator_from_seed",
    "record_from_json",
    "record_to_json",
    "seed_record",
]

RECORD_VERSION = 1
#: Kinds in draw order; each draws from its own stream.
KINDS: tuple[str, ...] = tuple(RANDOMIZATION_SCHEMA)


def seed_record(rng: np.random.Generator) -> dict[str, Any]:
    """What rebuilds ``rng`` from scratch (``generator_from_seed``): its seed sequence."""
    seq = rng.bit_generator.seed_seq
    entropy = seq.entropy
    entropy = int(entropy) if np.ndim(entropy) == 0 else [int(v) for v in entropy]
    return {
        "entropy": entropy,
        "spawn_key": [int(k) for k in seq.spawn_key],
        "bit_generator": type(rng.bit_generator).__name__,
    }


def generator_from_seed(seed: Mapping[str, Any]) -> np.random.Generator:
    """The generator described by ``seed_record`` (same stream, bit for bit)."""
    try:
        bit_generator = getattr(np.random, str(seed["bit_generator"]))
        seq = np.random.SeedSequence(seed["entropy"], spawn_key=tuple(seed["spawn_key"]))
        return np.random.Generator(bit_generator(seq))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise UserError(f"bad randomization seed record {dict(seed)!r:.80}: {exc}") from None


def _values(where: str, value: Any, size: int | None) -> Any:
    """Finite floats of the expected size (None: one number); one-line UserError if not."""
    try:
        if size is None:
            out = float(value)
            ok = math.isfinite(out) and not isinstance(value, (str, bytes))
        else:
            out = [float(v) for v in value]
            ok = len(out) == size and all(math.isfinite(v) for v in out)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        want = "a number" if size is None else f"{size} numbers"
        raise UserError(f"randomization record, {where}: expected {want}, got {value!r:.60}")
    return out


class NameIds:
    """Model name -> id, looked up once per name (``lookup_id``: errors list valid names)."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self._cache: dict[tuple[str, str], int] = {}

    def __call__(self, kind: str, name: str) -> int:
        key = (kind, name)
        if key not in self._cache:
            self._cache[key] = lookup_id(self.model, kind, str(name))
        return self._cache[key]


def apply_randomization(
    model: mujoco.MjModel,
    record: Mapping[str, Any],
    data: mujoco.MjData | None = None,
    ids: NameIds | None = None,
) -> None:
    """Write a randomization record into a model. Fields not in the record keep their
    current values, so apply it to a nominal model. Call ``mj_forward`` afterwards.

    Args:
        model: the model to write (names as in the record).
        record: the randomization record.
        data: where to write the initial arm joints (``joint_noise``); None: not written.
        ids: a name-lookup cache of this model, kept by ``SceneRandomizer``.

    Raises:
        UserError: not a record of this version, an unknown kind or name (lists the valid
            ones), or a value of the wrong size or not finite.
    """
    if not isinstance(record, Mapping) or record.get("version") != RECORD_VERSION:
        version = record.get("version") if isinstance(record, Mapping) else None
        raise UserError(
            f"not a randomization record of version {RECORD_VERSION} (got version {version!r})"
        )
    for kind, entries in record.items():
        if kind in ("version", "seed"):
            continue
        if kind not in KINDS:
            raise unknown_name_error("randomization kind", str(kind), KINDS)
        if not isinstance(entries, Mapping):
            raise UserError(f"randomization record, {kind}: expected a mapping of names")
        ids = ids or NameIds(model)
        for name, v in entries.items():
            _APPLY[kind](model, data, ids, name, v, f"{kind}.{name}")


def _get(where: str, v: Any, key: str) -> Any:
    if not isinstance(v, Mapping) or key not in v:
        raise UserError(f"randomization record, {where}: missing '{key}'")
    return v[key]


def _apply_light(model, data, ids, name, v, where):
    i = ids("light", name)
    for key, field in (
        ("dir", "light_dir"),
        ("diffuse", "light_diffuse"),
        ("specular", "light_specular"),
        ("ambient", "light_ambient"),
    ):
        getattr(model, field)[i] = _values(f"{where}.{key}", _get(where, v, key), 3)


def _apply_table(model, data, ids, name, v, where):
    g = ids("geom", name)
    material = _get(where, v, "material")
    if material:
        model.geom_matid[g] = ids("material", material)
    model.geom_rgba[g] = _values(f"{where}.rgba", _get(where, v, "rgba"), 4)


def _apply_object_colour(model, data, ids, name, v, where):
    model.geom_rgba[ids("geom", name)] = _values(where, v, 4)


def _apply_friction(model, data, ids, name, v, where):
    model.geom_friction[ids("geom", name), 0] = _values(where, v, None)


def _apply_mass(model, data, ids, name, v, where):
    b = ids("body", name)
    model.body_mass[b] = _values(f"{where}.mass", _get(where, v, "mass"), None)
    model.body_inertia[b] = _values(f"{where}.inertia", _get(where, v, "inertia"), 3)


def _apply_damping(model, data, ids, name, v, where):
    model.dof_damping[model.jnt_dofadr[ids("joint", name)]] = _values(where, v, None)


def _apply_camera(model, data, ids, name, v, where):
    c = ids("camera", name)
    model.cam_pos[c] = _values(f"{where}.pos", _get(where, v, "pos"), 3)
    model.cam_quat[c] = _values(f"{where}.quat", _get(where, v, "quat"), 4)


def _apply_joint_noise(model, data, ids, name, v, where):
    j = ids("joint", name)
    q = _values(f"{where}.qpos", _get(where, v, "qpos"), None)
    if data is not None:
        data.qpos[model.jnt_qposadr[j]] = q


_APPLY = {
    "lights": _apply_light,
    "table": _apply_table,
    "objects": _apply_object_colour,
    "friction": _apply_friction,
    "object_mass": _apply_mass,
    "joint_damping": _apply_damping,
    "camera": _apply_camera,
    "joint_noise": _apply_joint_noise,
}


def record_to_json(record: Mapping[str, Any]) -> str:
    """The record as JSON text (floats written exactly: they read back bit for bit)."""
    return json.dumps(record, separators=(",", ":"))


def record_from_json(text: str | bytes) -> dict[str, Any]:
    """A record from ``record_to_json`` text (e.g. an episode's ``randomization`` attr)."""
    try:
        record = json.loads(text)
    except (TypeError, ValueError) as exc:
        raise UserError(f"randomization record is not valid JSON: {exc}") from None
    if not isinstance(record, dict):
        raise UserError("randomization record must be a JSON object")
    return record
