"""Domain randomization (``tasks.randomization``): per kind, same seed same scene (model
fields and images), different seeds differ, ranges respected, off by default, no drift.
The records it samples: ``test_randomization_record.py``."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization import FIELDS
from trossen_arm_mujoco.tasks.randomization_record import KINDS
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_SCHEMA
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

#: kinds that change what a camera sees at reset (the others change dynamics only)
VISUAL = {"lights", "table", "objects", "camera", "joint_noise"}


def only(kind: str, **params) -> dict:
    """A randomization section with one kind on (with ``params``), every other kind off."""
    section = {k: {"enabled": k == kind} for k in KINDS}
    section[kind].update(params)
    return section


def make(kind: str | None = None, name: str = "push", **params):
    overrides = {} if kind is None else {"randomization": only(kind, **params)}
    return registry.make_sampler(
        name,
        SamplerSettings(randomize=kind is not None, camera_names=["overview"], height=32, width=40),
        **overrides,
    )


def fields(sampler) -> dict[str, np.ndarray]:
    model = sampler.scene.model
    return {f: getattr(model, f).copy() for f in FIELDS}


def snapshot(sampler, seed: int):
    """(model fields, qpos, image) of episode ``seed``; the image is the second render of
    the episode's first state (the same position in every call)."""
    sampler.sample_task(seed)
    sampler.scene.render_images()
    image = sampler.scene.render_images()["overview"]
    return fields(sampler), sampler.scene.data.qpos.copy(), image


def same(a, b) -> bool:
    fa, qa, ia = a
    fb, qb, ib = b
    return all(np.array_equal(fa[f], fb[f]) for f in FIELDS) and (
        np.array_equal(qa, qb) and np.array_equal(ia, ib)
    )


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_scene_different_seeds_differ(kind):
    sampler = make(kind)
    try:
        first = snapshot(sampler, 1)
        other = snapshot(sampler, 2)
        again = snapshot(sampler, 1)
        assert same(first, again)
        assert list(sampler.randomization) == ["version", "seed", kind]
        changed = [f for f in FIELDS if not np.array_equal(first[0][f], other[0][f])]
        if kind == "joint_noise":
            assert not changed and not np.array_equal(first[1], other[1])
        else:
            assert changed
        if kind in VISUAL:
            assert not np.array_equal(first[2], other[2])
    finally:
        sampler.close()


def test_off_by_default_and_nominal():
    plain = registry.make_sampler("push")
    loaded = mujoco.MjModel.from_xml_path(str(_scene("push")))
    try:
        assert plain.randomize is False
        plain.sample_task(3)
        assert plain.randomization is None
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(plain.scene.model, f), getattr(loaded, f))
    finally:
        plain.close()


def _scene(name: str):
    from trossen_arm_mujoco.assets import ASSETS_DIR

    return Path(ASSETS_DIR) / registry.load(name).load_config()["scene"]


def test_repeated_episodes_do_not_drift_and_switching_off_restores_nominal():
    sampler = registry.make_sampler("sim_transfer_cube", SamplerSettings(randomize=True))
    try:
        nominal = sampler.randomizer.nominal
        sampler.sample_task(5)
        first = fields(sampler)
        for seed in range(20):
            sampler.sample_task(seed)
        sampler.sample_task(5)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(sampler.scene.model, f), first[f])
        sampler.randomize = False
        sampler.sample_task(5)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(sampler.scene.model, f), nominal[f])
    finally:
        sampler.close()


def test_task_episode_is_the_same_with_and_without_randomization():
    """Randomization draws from a child stream: object poses and goals do not move."""
    plain, randomized = (
        registry.make_sampler("push"),
        registry.make_sampler("push", SamplerSettings(randomize=True)),
    )
    try:
        for seed in (0, 1):
            a, b = plain.sample_task(seed), randomized.sample_task(seed)
            np.testing.assert_array_equal(a.cube.get_pose(a.data), b.cube.get_pose(b.data))
            np.testing.assert_array_equal(a.desired_goal(), b.desired_goal())
    finally:
        plain.close()
        randomized.close()


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))


def _within(value, low, high, tol: float = 1e-6) -> None:
    value = np.asarray(value, dtype=float)
    assert np.all(value >= np.asarray(low) - tol) and np.all(value <= np.asarray(high) + tol)


def test_ranges_are_respected():
    section = {
        "lights": {
            "direction_deg": 10.0,
            "diffuse_scale": [1.1, 1.3],
            "specular_scale": [0.7, 0.8],
            "ambient": [0.05, 0.1],
            "colour_jitter": 0.05,
        },
        "table": {"materials": ["groundplane", "table_leg"], "rgb_jitter": 0.1},
        "objects": {"rgb_jitter": 0.1},
        "friction": {"scale": [1.5, 1.6]},
        "object_mass": {"scale": [2.0, 3.0]},
        "joint_damping": {"range": [0.2, 0.3]},
        "camera": {"position": 0.01, "orientation_deg": 3.0},
        "joint_noise": {"range": 0.05},
    }
    sampler = registry.make_sampler("push", SamplerSettings(randomize=True), randomization=section)
    model, r = sampler.scene.model, sampler.randomizer
    nom = r.nominal
    mats, picked = {"groundplane", "table_leg"}, set()
    try:
        for seed in range(60):
            sampler.scene.reset()
            q0 = sampler.scene.data.qpos.copy()
            rec = r.sample(np.random.default_rng(seed), sampler.scene.data)
            for name, v in rec["lights"].items():
                i = model.light(name).id
                assert _angle(np.array(v["dir"]), nom["light_dir"][i]) <= 10.0 + 1e-6
                for key, lo, hi in (("diffuse", 1.1, 1.3), ("specular", 0.7, 0.8)):
                    nominal = nom[f"light_{key}"][i]
                    _within(v[key], nominal * lo * 0.95, nominal * hi * 1.05)
                nominal = nom["light_ambient"][i]
                _within(v["ambient"], (nominal + 0.05) * 0.95, (nominal + 0.1) * 1.05)
            (table,) = rec["table"].values()
            picked.add(table["material"])
            base = model.mat_rgba[model.mat(table["material"]).id][:3]
            assert np.all(np.abs(np.array(table["rgba"][:3]) - base) <= 0.1 + 1e-6)
            cube = nom["geom_rgba"][model.geom("cube").id]
            _within(rec["objects"]["cube"][:3], cube[:3] - 0.1, cube[:3] + 0.1)
            for geom, f in rec["friction"].items():
                nominal = nom["geom_friction"][model.geom(geom).id, 0]
                _within(f, 1.5 * nominal, 1.6 * nominal)
            mass = nom["body_mass"][model.body("cube").id]
            _within(rec["object_mass"]["cube"]["mass"], 2.0 * mass, 3.0 * mass)
            for joint, d in rec["joint_damping"].items():
                nominal = nom["dof_damping"][model.joint(joint).dofadr[0]]
                _within(d, nominal + 0.2, nominal + 0.3)
            for cam, v in rec["camera"].items():
                c = model.cam(cam).id
                assert np.all(np.abs(np.array(v["pos"]) - nom["cam_pos"][c]) <= 0.01 + 1e-12)
                dot = abs(float(np.dot(v["quat"], nom["cam_quat"][c])))
                assert math.degrees(2 * math.acos(min(1.0, dot))) <= 3.0 + 1e-6
            assert len(rec["joint_noise"]) == 6
            for joint, v in rec["joint_noise"].items():
                assert abs(v["noise"]) <= 0.05
                assert v["qpos"] == pytest.approx(q0[model.joint(joint).qposadr[0]] + v["noise"])
        assert picked == mats
    finally:
        sampler.close()


def test_unknown_table_name_lists_valid_names():
    with pytest.raises(UserError, match="unknown geom 'tabel'.*table"):
        registry.make_sampler("reach", randomization={"table": {"geoms": ["tabel"]}})
    with pytest.raises(UserError, match="unknown material 'oak'.*maple"):
        registry.make_sampler("reach", randomization={"table": {"materials": ["oak"]}})


def test_every_shipped_config_randomizes_every_kind():
    for name in registry.names():
        if registry.load(name).package != "trossen_arm_mujoco":
            continue  # an installed package's task (examples/my_trossen_task): not shipped
        section = registry.load(name).load_config()["randomization"]
        assert set(section) == set(RANDOMIZATION_SCHEMA)
        assert all(section[k]["enabled"] for k in section)
        with registry.make_sampler(name, SamplerSettings(randomize=True)) as sampler:
            sampler.sample_task(0)
            assert set(sampler.randomization) == {"version", "seed", *KINDS}
            object_kinds = {"objects", "object_mass"} if not sampler.scene.objects else set()
            assert all(sampler.randomization[k] for k in set(KINDS) - object_kinds), name
