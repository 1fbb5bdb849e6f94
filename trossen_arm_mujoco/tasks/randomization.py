"""Domain randomization of a scene, written into ``MjModel`` fields.

``SceneRandomizer`` saves the nominal values of every field it may touch when it is built;
each episode starts from those (``restore``), so repeated episodes never drift. What it
samples is a *record* (``tasks.randomization_record``: a plain, JSON-able dict of every
sampled value, in absolute units, keyed by model names), applied with
``apply_randomization``.

Randomness: ``randomize(rng, data)`` draws from a child of ``rng`` (``Generator.spawn``),
which leaves ``rng``'s own stream untouched: a task's episode (object poses, goals, policy
noise) is the same with and without randomization. Each kind has its own grandchild stream,
so switching one kind off does not change the others. The child's seed is in the record.

Docs: docs/concepts/randomization.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.tasks.randomization_record import (
    KINDS,
    RECORD_VERSION,
    NameIds,
    apply_randomization,
    seed_record,
)

__all__ = ["FIELDS", "SceneRandomizer", "episode_generator"]

#: Model fields a randomization may write (saved at construction, restored every episode).
FIELDS = (
    "light_dir",
    "light_diffuse",
    "light_specular",
    "light_ambient",
    "geom_rgba",
    "geom_matid",
    "geom_friction",
    "body_mass",
    "body_inertia",
    "dof_damping",
    "cam_pos",
    "cam_quat",
)
_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)


def episode_generator(rng: np.random.Generator) -> np.random.Generator:
    """An independent child of ``rng`` that leaves ``rng``'s stream as it was (a generator
    without a seed sequence gives one drawn from its stream instead)."""
    try:
        return rng.spawn(1)[0]
    except (TypeError, AttributeError, ValueError):
        return np.random.default_rng(int(rng.integers(2**63)))


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
        self._ids = NameIds(model)

    @property
    def enabled_kinds(self) -> list[str]:
        """The randomization kinds switched on (``enabled``) in the settings, in ``KINDS`` order."""
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
        return {
            name: {
                "dir": directions[k],
                "diffuse": diffuse[k],
                "specular": specular[k],
                "ambient": ambient[k],
            }
            for k, name in enumerate(names)
        }

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
            out[name] = {
                "material": mat_name or "",
                "rgba": self._jittered(self._rgba(geom, material), jitter),
            }
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
