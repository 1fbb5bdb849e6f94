"""Domain randomization of a scene, written into ``MjModel`` fields.

``SceneRandomizer`` saves the nominal values of every field it may touch when it is built;
each episode starts from those (``restore``), so repeated episodes never drift. A
randomization is a *record*: a plain, JSON-able dict of every sampled value, in absolute
units, keyed by model names::

    {"version": 1, "seed": {"entropy": ..., "spawn_key": [...], "bit_generator": "PCG64"},
     "lights": {light: {"dir": [3], "diffuse": [3], "specular": [3], "ambient": [3]}},
     "table": {geom: {"material": name, "rgba": [4]}},
     "objects": {geom: [4] rgba},
     "friction": {geom: sliding friction},
     "object_mass": {body: {"mass": kg, "inertia": [3] kg m^2}},
     "joint_damping": {joint: damping},
     "camera": {camera: {"pos": [3] m, "quat": [4] wxyz}},      # in the parent body frame
     "joint_noise": {joint: {"noise": rad, "qpos": rad}}}         # initial arm joints

Only enabled kinds appear. ``apply_randomization(model, record, data)`` writes a record into
any model with those names (e.g. to re-render a recorded episode, or to give the joint
flavour of a task the scene its end-effector flavour was randomized with); stored as JSON
with ``record_to_json`` / ``record_from_json``.

Randomness: ``randomize(rng, data)`` draws from a child of ``rng`` (``Generator.spawn``),
which leaves ``rng``'s own stream untouched: a task's episode (object poses, goals, policy
noise) is the same with and without randomization. Each kind has its own grandchild stream,
so switching one kind off does not change the others. The child's seed is in the record.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.tasks.config import RANDOMIZATION_SCHEMA

RECORD_VERSION = 1
#: Kinds in draw order; each draws from its own stream.
KINDS: tuple[str, ...] = tuple(RANDOMIZATION_SCHEMA)
#: Model fields a randomization may write (saved at construction, restored every episode).
FIELDS = ("light_dir", "light_diffuse", "light_specular", "light_ambient", "geom_rgba",
          "geom_matid", "geom_friction", "body_mass", "body_inertia", "dof_damping",
          "cam_pos", "cam_quat")  # fmt: skip
_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)


def episode_generator(rng: np.random.Generator) -> np.random.Generator:
    """An independent child of ``rng`` that leaves ``rng``'s stream as it was (a generator
    without a seed sequence gives one drawn from its stream instead)."""
    try:
        return rng.spawn(1)[0]
    except (TypeError, AttributeError, ValueError):
        return np.random.default_rng(int(rng.integers(2**63)))


def seed_record(rng: np.random.Generator) -> dict[str, Any]:
    """What rebuilds ``rng`` from scratch (``generator_from_seed``): its seed sequence."""
    seq = rng.bit_generator.seed_seq
    entropy = seq.entropy
    entropy = int(entropy) if np.ndim(entropy) == 0 else [int(v) for v in entropy]
    return {"entropy": entropy, "spawn_key": [int(k) for k in seq.spawn_key],
            "bit_generator": type(rng.bit_generator).__name__}  # fmt: skip


def generator_from_seed(seed: Mapping[str, Any]) -> np.random.Generator:
    """The generator described by ``seed_record`` (same stream, bit for bit)."""
    try:
        bit_generator = getattr(np.random, str(seed["bit_generator"]))
        seq = np.random.SeedSequence(seed["entropy"], spawn_key=tuple(seed["spawn_key"]))
        return np.random.Generator(bit_generator(seq))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise UserError(f"bad randomization seed record {dict(seed)!r:.80}: {exc}") from None


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``v`` rotated by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1.0 - c)


def _random_axis(g: np.random.Generator) -> np.ndarray:
    axis = g.normal(size=3)
    return axis / max(float(np.linalg.norm(axis)), 1e-12)


def _named(model: mujoco.MjModel, obj: mujoco.mjtObj, ids) -> list[tuple[int, str]]:
    """(id, name) of the elements of ``ids`` that have a name."""
    out = [(int(i), mujoco.mj_id2name(model, obj, int(i))) for i in ids]
    return [(i, n) for i, n in out if n]


class SceneRandomizer:
    """Samples and applies randomizations of one scene (see the module docstring).

    Args:
        model: the scene's model; its fields are written in place.
        settings: the task config's ``randomization`` section (validated by
            ``tasks.config``): which kinds are on and their ranges.
        object_bodies: bodies of the task's free objects (colours, masses).
        arm_joints: joints of the arms (initial joint noise; rad).
        robot_joints: every joint of the robot (damping).

    Names (table geoms and materials) are looked up here; an unknown one is a UserError
    listing the valid names.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        settings: Mapping[str, Any],
        *,
        object_bodies: Sequence[int] = (),
        arm_joints: Sequence[int] = (),
        robot_joints: Sequence[int] = (),
    ):
        self.model = model
        self.settings = {kind: dict(settings[kind]) for kind in KINDS}
        obj = mujoco.mjtObj
        table = self.settings["table"]
        self.table_geoms = [(lookup_id(model, "geom", n), n) for n in table["geoms"]]
        self.table_materials = [(lookup_id(model, "material", n), n) for n in table["materials"]]
        self.lights = _named(model, obj.mjOBJ_LIGHT, range(model.nlight))
        self.cameras = _named(model, obj.mjOBJ_CAMERA, range(model.ncam))
        bodies = [int(b) for b in object_bodies]
        self.object_bodies = _named(model, obj.mjOBJ_BODY, bodies)
        self.object_geoms = [
            _named(model, obj.mjOBJ_GEOM, np.flatnonzero(model.geom_bodyid == b)) for b in bodies
        ]
        colliding = np.flatnonzero((model.geom_contype != 0) | (model.geom_conaffinity != 0))
        self.friction_geoms = _named(model, obj.mjOBJ_GEOM, colliding)
        self.arm_joints = _named(model, obj.mjOBJ_JOINT, arm_joints)
        self.robot_joints = _named(model, obj.mjOBJ_JOINT, robot_joints)
        self.nominal = {f: getattr(model, f).copy() for f in FIELDS}
        self._dirty = False

    @property
    def enabled_kinds(self) -> list[str]:
        return [k for k in KINDS if self.settings[k]["enabled"]]

    # -- model state ----------------------------------------------------------------------
    def restore(self) -> None:
        """Every randomized field back to its nominal value (bit for bit)."""
        if self._dirty:
            for field, value in self.nominal.items():
                getattr(self.model, field)[...] = value
            self._dirty = False

    def apply(self, record: Mapping[str, Any], data: mujoco.MjData | None = None) -> None:
        """Nominal scene, then ``record`` written into the model (and the initial joints
        into ``data``). Call ``mj_forward`` afterwards."""
        self.restore()
        self._dirty = True
        apply_randomization(self.model, record, data)

    def randomize(self, rng: np.random.Generator, data: mujoco.MjData) -> dict[str, Any]:
        """Sample a randomization from a child of ``rng`` and apply it; returns its record."""
        record = self.sample(episode_generator(rng), data)
        self.apply(record, data)
        return record

    # -- sampling -------------------------------------------------------------------------
    def sample(self, rng: np.random.Generator, data: mujoco.MjData) -> dict[str, Any]:
        """A record drawn from ``rng`` (from the nominal values and ``data``'s joints);
        writes nothing."""
        streams = dict(zip(KINDS, rng.spawn(len(KINDS)), strict=True))
        record: dict[str, Any] = {"version": RECORD_VERSION, "seed": seed_record(rng)}
        for kind in self.enabled_kinds:
            record[kind] = getattr(self, f"_sample_{kind}")(
                streams[kind], self.settings[kind], data
            )
        return record

    def _f32(self, values) -> list[float]:
        return np.asarray(values, dtype=np.float32).tolist()

    def _sample_lights(self, g, s, data):
        nom, out = self.nominal, {}
        c, max_tilt = s["colour_jitter"], math.radians(s["direction_deg"])
        for i, name in self.lights:
            axis, tilt = _random_axis(g), g.uniform(0.0, max_tilt)
            direction = _rotate(nom["light_dir"][i], axis, tilt)
            tint = g.uniform(1.0 - c, 1.0 + c, 3)
            diffuse = nom["light_diffuse"][i] * g.uniform(*s["diffuse_scale"]) * tint
            specular = nom["light_specular"][i] * g.uniform(*s["specular_scale"]) * tint
            ambient = (nom["light_ambient"][i] + g.uniform(*s["ambient"])) * tint
            out[name] = {"dir": (direction / np.linalg.norm(direction)).tolist(),
                         "diffuse": self._f32(diffuse), "specular": self._f32(specular),
                         "ambient": self._f32(ambient)}  # fmt: skip
        return out

    def _rgba(self, geom: int, material: int | None = None) -> np.ndarray:
        """Colour a geom shows (its material's when its own rgba is the default)."""
        nom = self.nominal
        own = nom["geom_rgba"][geom]
        mat = int(nom["geom_matid"][geom]) if material is None else material
        if mat >= 0 and np.array_equal(own, _DEFAULT_RGBA):
            return self.model.mat_rgba[mat].astype(np.float64)
        return own.astype(np.float64)

    def _jittered(self, rgba: np.ndarray, jitter: np.ndarray) -> list[float]:
        out = rgba.copy()
        out[:3] = np.clip(out[:3] + jitter, 0.0, 1.0)
        return self._f32(out)

    def _sample_table(self, g, s, data):
        out, j = {}, s["rgb_jitter"]
        for geom, name in self.table_geoms:
            material = int(self.nominal["geom_matid"][geom])
            mat_name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_MATERIAL, material)
            if self.table_materials:
                material, mat_name = self.table_materials[
                    int(g.integers(len(self.table_materials)))
                ]
            jitter = g.uniform(-j, j, 3)
            out[name] = {"material": mat_name or "",
                         "rgba": self._jittered(self._rgba(geom, material), jitter)}  # fmt: skip
        return out

    def _sample_objects(self, g, s, data):
        out, j = {}, s["rgb_jitter"]
        for geoms in self.object_geoms:
            jitter = g.uniform(-j, j, 3)  # one colour change per object
            for geom, name in geoms:
                out[name] = self._jittered(self._rgba(geom), jitter)
        return out

    def _sample_friction(self, g, s, data):
        nom = self.nominal["geom_friction"]
        return {name: float(nom[i, 0] * g.uniform(*s["scale"])) for i, name in self.friction_geoms}

    def _sample_object_mass(self, g, s, data):
        nom, out = self.nominal, {}
        for body, name in self.object_bodies:
            k = g.uniform(*s["scale"])
            out[name] = {"mass": float(nom["body_mass"][body] * k),
                         "inertia": (nom["body_inertia"][body] * k).tolist()}  # fmt: skip
        return out

    def _sample_joint_damping(self, g, s, data):
        nom, adr = self.nominal["dof_damping"], self.model.jnt_dofadr
        return {name: float(nom[adr[j]] + g.uniform(*s["range"])) for j, name in self.robot_joints}

    def _sample_camera(self, g, s, data):
        nom, out = self.nominal, {}
        p, max_angle = s["position"], math.radians(s["orientation_deg"])
        for cam, name in self.cameras:
            pos = nom["cam_pos"][cam] + g.uniform(-p, p, 3)
            axis, angle = _random_axis(g), g.uniform(0.0, max_angle)
            turn = np.concatenate([[math.cos(angle / 2)], axis * math.sin(angle / 2)])
            quat = np.empty(4)
            mujoco.mju_mulQuat(quat, nom["cam_quat"][cam], turn)
            out[name] = {"pos": pos.tolist(), "quat": (quat / np.linalg.norm(quat)).tolist()}
        return out

    def _sample_joint_noise(self, g, s, data):
        out, r, model = {}, s["range"], self.model
        for j, name in self.arm_joints:
            q = float(data.qpos[model.jnt_qposadr[j]])
            noise = float(g.uniform(-r, r))
            low, high = model.jnt_range[j] if model.jnt_limited[j] else (-np.inf, np.inf)
            out[name] = {"noise": noise, "qpos": float(np.clip(q + noise, low, high))}
        return out


# -- applying a record --------------------------------------------------------------------
def _values(where: str, value: Any, size: int | None) -> np.ndarray:
    """Finite floats of the expected size (None: one number); one-line UserError if not."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    ok = arr.shape == (() if size is None else (size,)) and np.all(np.isfinite(arr))
    if not ok:
        want = "a number" if size is None else f"{size} numbers"
        raise UserError(f"randomization record, {where}: expected {want}, got {value!r:.60}")
    return arr


def apply_randomization(
    model: mujoco.MjModel, record: Mapping[str, Any], data: mujoco.MjData | None = None
) -> None:
    """Write a randomization record into ``model`` (and the initial arm joints into
    ``data`` when given). Fields not in the record keep their current values, so apply it
    to a nominal model. Call ``mj_forward`` afterwards.

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
        for name, v in entries.items():
            _APPLY[kind](model, data, name, v, f"{kind}.{name}")


def _get(where: str, v: Any, key: str) -> Any:
    if not isinstance(v, Mapping) or key not in v:
        raise UserError(f"randomization record, {where}: missing '{key}'")
    return v[key]


def _apply_light(model, data, name, v, where):
    i = lookup_id(model, "light", name)
    for key, field in (("dir", "light_dir"), ("diffuse", "light_diffuse"),
                       ("specular", "light_specular"), ("ambient", "light_ambient")):  # fmt: skip
        getattr(model, field)[i] = _values(f"{where}.{key}", _get(where, v, key), 3)


def _apply_table(model, data, name, v, where):
    g = lookup_id(model, "geom", name)
    material = _get(where, v, "material")
    if material:
        model.geom_matid[g] = lookup_id(model, "material", str(material))
    model.geom_rgba[g] = _values(f"{where}.rgba", _get(where, v, "rgba"), 4)


def _apply_object_colour(model, data, name, v, where):
    model.geom_rgba[lookup_id(model, "geom", name)] = _values(where, v, 4)


def _apply_friction(model, data, name, v, where):
    model.geom_friction[lookup_id(model, "geom", name), 0] = _values(where, v, None)


def _apply_mass(model, data, name, v, where):
    b = lookup_id(model, "body", name)
    model.body_mass[b] = _values(f"{where}.mass", _get(where, v, "mass"), None)
    model.body_inertia[b] = _values(f"{where}.inertia", _get(where, v, "inertia"), 3)


def _apply_damping(model, data, name, v, where):
    model.dof_damping[model.jnt_dofadr[lookup_id(model, "joint", name)]] = _values(where, v, None)


def _apply_camera(model, data, name, v, where):
    c = lookup_id(model, "camera", name)
    model.cam_pos[c] = _values(f"{where}.pos", _get(where, v, "pos"), 3)
    model.cam_quat[c] = _values(f"{where}.quat", _get(where, v, "quat"), 4)


def _apply_joint_noise(model, data, name, v, where):
    j = lookup_id(model, "joint", name)
    q = _values(f"{where}.qpos", _get(where, v, "qpos"), None)
    if data is not None:
        data.qpos[model.jnt_qposadr[j]] = q


_APPLY = {"lights": _apply_light, "table": _apply_table, "objects": _apply_object_colour,
          "friction": _apply_friction, "object_mass": _apply_mass,
          "joint_damping": _apply_damping, "camera": _apply_camera,
          "joint_noise": _apply_joint_noise}  # fmt: skip


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
