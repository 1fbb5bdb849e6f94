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
        self._ids = _Ids(model)

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
        apply_randomization(self.model, record, data, self._ids)

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

    @staticmethod
    def _f32(values) -> list:
        """Values as the float32 fields hold them (so the record equals the model)."""
        return np.asarray(values, dtype=np.float32).tolist()

    def _sample_lights(self, g, s, data):
        ids, names = _split(self.lights)
        n, nom = len(ids), self.nominal
        c = s["colour_jitter"]
        axes = _unit_rows(g.normal(size=(n, 3)))
        tilts = g.uniform(0.0, math.radians(s["direction_deg"]), n)
        tints = g.uniform(1.0 - c, 1.0 + c, (n, 3))
        k_diffuse = g.uniform(*s["diffuse_scale"], n)[:, None]
        k_specular = g.uniform(*s["specular_scale"], n)[:, None]
        ambient_add = g.uniform(*s["ambient"], n)[:, None]
        directions = _unit_rows(_rotate_rows(nom["light_dir"][ids], axes, tilts)).tolist()
        diffuse = self._f32(nom["light_diffuse"][ids] * k_diffuse * tints)
        specular = self._f32(nom["light_specular"][ids] * k_specular * tints)
        ambient = self._f32((nom["light_ambient"][ids] + ambient_add) * tints)
        return {name: {"dir": directions[k], "diffuse": diffuse[k], "specular": specular[k],
                       "ambient": ambient[k]} for k, name in enumerate(names)}  # fmt: skip

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
                choice = int(g.integers(len(self.table_materials)))
                material, mat_name = self.table_materials[choice]
            jitter = g.uniform(-j, j, 3)
            out[name] = {"material": mat_name or "",
                         "rgba": self._jittered(self._rgba(geom, material), jitter)}  # fmt: skip
        return out

    def _sample_objects(self, g, s, data):
        out, j = {}, s["rgb_jitter"]
        jitters = g.uniform(-j, j, (len(self.object_geoms), 3))  # one colour change per object
        for geoms, jitter in zip(self.object_geoms, jitters, strict=True):
            for geom, name in geoms:
                out[name] = self._jittered(self._rgba(geom), jitter)
        return out

    def _sample_friction(self, g, s, data):
        ids, names = _split(self.friction_geoms)
        values = self.nominal["geom_friction"][ids, 0] * g.uniform(*s["scale"], len(ids))
        return dict(zip(names, values.tolist(), strict=True))

    def _sample_object_mass(self, g, s, data):
        ids, names = _split(self.object_bodies)
        k = g.uniform(*s["scale"], len(ids))
        mass = (self.nominal["body_mass"][ids] * k).tolist()
        inertia = (self.nominal["body_inertia"][ids] * k[:, None]).tolist()
        return {name: {"mass": mass[i], "inertia": inertia[i]} for i, name in enumerate(names)}

    def _sample_joint_damping(self, g, s, data):
        ids, names = _split(self.robot_joints)
        nominal = self.nominal["dof_damping"][self.model.jnt_dofadr[ids]]
        return dict(zip(names, (nominal + g.uniform(*s["range"], len(ids))).tolist(), strict=True))

    def _sample_camera(self, g, s, data):
        ids, names = _split(self.cameras)
        n, nom, p = len(ids), self.nominal, s["position"]
        pos = (nom["cam_pos"][ids] + g.uniform(-p, p, (n, 3))).tolist()
        axes = _unit_rows(g.normal(size=(n, 3)))
        half = 0.5 * g.uniform(0.0, math.radians(s["orientation_deg"]), n)
        turns = np.column_stack([np.cos(half), axes * np.sin(half)[:, None]])
        quats = _unit_rows(_quat_mul_rows(nom["cam_quat"][ids], turns)).tolist()
        return {name: {"pos": pos[k], "quat": quats[k]} for k, name in enumerate(names)}

    def _sample_joint_noise(self, g, s, data):
        ids, names = _split(self.arm_joints)
        model, r = self.model, s["range"]
        noise = g.uniform(-r, r, len(ids))
        limited = model.jnt_limited[ids].astype(bool)
        low = np.where(limited, model.jnt_range[ids, 0], -np.inf)
        high = np.where(limited, model.jnt_range[ids, 1], np.inf)
        qpos = np.clip(data.qpos[model.jnt_qposadr[ids]] + noise, low, high).tolist()
        return {name: {"noise": float(noise[k]), "qpos": qpos[k]} for k, name in enumerate(names)}


def _split(named: list[tuple[int, str]]) -> tuple[np.ndarray, list[str]]:
    return np.array([i for i, _ in named], dtype=int), [n for _, n in named]


def _cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products (np.cross, without its overhead on small arrays)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.column_stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)


def _rotate_rows(v: np.ndarray, axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Each row of ``v`` rotated by ``angles`` (rad) about the unit ``axes`` (Rodrigues)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    along = np.sum(axes * v, axis=1, keepdims=True)
    return v * c + _cross_rows(axes, v) * s + axes * along * (1.0 - c)


def _quat_mul_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise quaternion products a * b (wxyz)."""
    w1, v1, w2, v2 = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    w = w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True)
    return np.column_stack([w, w1 * v2 + w2 * v1 + _cross_rows(v1, v2)])


# -- applying a record --------------------------------------------------------------------
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


class _Ids:
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
    ids: _Ids | None = None,
) -> None:
    """Write a randomization record into ``model`` (and the initial arm joints into
    ``data`` when given). Fields not in the record keep their current values, so apply it
    to a nominal model. Call ``mj_forward`` afterwards. (``ids``: a name-lookup cache of
    this model, kept by ``SceneRandomizer``.)

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
        ids = ids or _Ids(model)
        for name, v in entries.items():
            _APPLY[kind](model, data, ids, name, v, f"{kind}.{name}")


def _get(where: str, v: Any, key: str) -> Any:
    if not isinstance(v, Mapping) or key not in v:
        raise UserError(f"randomization record, {where}: missing '{key}'")
    return v[key]


def _apply_light(model, data, ids, name, v, where):
    i = ids("light", name)
    for key, field in (("dir", "light_dir"), ("diffuse", "light_diffuse"),
                       ("specular", "light_specular"), ("ambient", "light_ambient")):  # fmt: skip
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
