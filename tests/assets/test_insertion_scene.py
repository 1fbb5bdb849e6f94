"""The peg-insertion scenes (mocap and joint flavours): generated, compiling, named, sized
for the real gripper, and with the objects resting still on the table."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pytest
from dm_control import mujoco as dm_mujoco

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE, STATIONARY_CAMERAS
from trossen_arm_mujoco.names import names_of
from trossen_arm_mujoco.tasks.insertion import (
    PEG_HALF,
    PEG_REST_Z,
    PIN_FACE_Y,
    SOCKET_GEOMS,
    SOCKET_HALF_LENGTH,
    SOCKET_INNER_HALF,
    SOCKET_MOUTH_Y,
    SOCKET_OUTER_HALF,
    SOCKET_REST_Z,
    InsertionReward,
)

ASSETS = Path(ASSETS_DIR)
MOCAP = "stationary_ai/trossen_ai_insertion_scene.xml"
JOINT = "stationary_ai/trossen_ai_insertion_scene_joint.xml"
CUBE_SCENES = {
    MOCAP: "stationary_ai/trossen_ai_scene.xml",
    JOINT: "stationary_ai/trossen_ai_scene_joint.xml",
}
BUILD_MODELS = Path(__file__).resolve().parents[2] / "tools" / "build_models.py"
#: Real gripper: 0.044 m travel per finger, i.e. an 88 mm opening.
MAX_GRIPPER_GAP = 0.088


def load(rel: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(ASSETS / rel))


@pytest.fixture(scope="module", params=[MOCAP, JOINT])
def scene(request):
    return request.param, load(request.param)


def test_generator_writes_both_flavours():
    if not BUILD_MODELS.is_file():
        pytest.skip("tools/build_models.py is not in this checkout")
    spec = importlib.util.spec_from_file_location("build_models_insertion", BUILD_MODELS)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    generated = module.generate()
    for rel in (MOCAP, JOINT):
        assert (ASSETS / rel).read_text() == generated[rel], "run python tools/build_models.py"


def test_loads_in_dm_control(scene):
    rel, model = scene
    physics = dm_mujoco.Physics.from_xml_path(str(ASSETS / rel))
    assert physics.model.nq == model.nq == 30
    assert physics.model.name2id("peg_joint", "joint") == 16
    assert physics.model.name2id("socket_joint", "joint") == 17
    assert physics.named.data.qpos["socket_joint"].shape == (7,)


def test_names_and_qpos_layout(scene):
    _, model = scene
    geoms = names_of(model, "geom")
    for name in ("peg", *SOCKET_GEOMS, "table"):
        assert name in geoms
    for side in ("left", "right"):
        for finger in ("left", "right"):
            for part in ("", "_pad_upper", "_pad_lower"):
                assert f"{side}/gripper_follower_{finger}{part}" in geoms
        assert f"{side}/ee_site" in names_of(model, "site")
    assert names_of(model, "camera") == list(STATIONARY_CAMERAS)
    # qpos: 16 arm values, then the peg (16..22), then the socket (23..29)
    for joint, adr, dof in (("peg_joint", 16, 16), ("socket_joint", 23, 22)):
        jid = model.joint(joint).id
        assert model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_FREE
        assert model.jnt_qposadr[jid] == adr and model.jnt_dofadr[jid] == dof
    assert model.nq == 30 and model.nv == 28
    assert model.geom("peg").bodyid[0] == model.body("peg").id
    for name in SOCKET_GEOMS:
        assert model.geom(name).bodyid[0] == model.body("socket").id
    InsertionReward(model)  # looks up every name it needs


def test_same_options_and_actuators_as_the_cube_scenes(scene):
    rel, model = scene
    cube = load(CUBE_SCENES[rel])
    assert model.opt.timestep == cube.opt.timestep
    assert model.opt.integrator == cube.opt.integrator
    assert model.opt.cone == cube.opt.cone and model.opt.impratio == cube.opt.impratio
    assert names_of(model, "actuator") == names_of(cube, "actuator")
    assert names_of(model, "equality") == names_of(cube, "equality")
    assert model.nmocap == cube.nmocap
    np.testing.assert_array_equal(model.actuator_gainprm, cube.actuator_gainprm)
    if rel == MOCAP:
        assert model.nu == 2 and model.nmocap == 2
        np.testing.assert_allclose(model.key("home").mpos, cube.key("home").mpos)
        np.testing.assert_allclose(model.key("home").mquat, cube.key("home").mquat)
    else:
        assert model.nu == 14 and model.nmocap == 0
    np.testing.assert_allclose(model.key("home").ctrl, cube.key("home").ctrl)


def test_sizes_fit_the_gripper_and_each_other():
    model = load(JOINT)
    peg = model.geom("peg").size
    np.testing.assert_allclose(peg, PEG_HALF)
    walls = {n: (model.geom(n).size, model.geom(n).pos) for n in SOCKET_GEOMS}
    # inner faces of the side walls and of the lower/upper walls: the hole
    inner_x = walls["socket-3"][1][0] - walls["socket-3"][0][0]
    inner_z = walls["socket-2"][1][2] - walls["socket-2"][0][2]
    assert inner_x == pytest.approx(SOCKET_INNER_HALF) and inner_z == pytest.approx(inner_x)
    clearance = SOCKET_INNER_HALF - PEG_HALF[0]
    assert 0.002 <= clearance <= 0.004  # a few mm around the peg
    outer = walls["socket-3"][1][0] + walls["socket-3"][0][0]
    assert outer == pytest.approx(SOCKET_OUTER_HALF)
    assert walls["socket-1"][0][1] == pytest.approx(SOCKET_HALF_LENGTH)
    # grasped across x: both fit the 88 mm opening with room to spare
    assert 2 * PEG_HALF[0] < MAX_GRIPPER_GAP / 2 and 2 * outer < MAX_GRIPPER_GAP / 2
    # the pin sits on the inside of the bottom; its face is PIN_FACE_Y from the centre
    pin_size, pin_pos = walls["pin"]
    bottom_size, bottom_pos = walls["socket-bottom"]
    assert pin_pos[1] + pin_size[1] == pytest.approx(bottom_pos[1] - bottom_size[1])
    assert pin_pos[1] - pin_size[1] == pytest.approx(PIN_FACE_Y)
    assert walls["socket-1"][1][1] - walls["socket-1"][0][1] == pytest.approx(SOCKET_MOUTH_Y)
    # the peg reaches the pin well before its grasp (long enough to insert)
    assert PIN_FACE_Y - SOCKET_MOUTH_Y < PEG_HALF[1]


def test_masses_are_realistic():
    model = load(JOINT)
    for body in ("peg", "socket"):
        mass = model.body(body).mass[0]
        assert 0.01 < mass < 0.1, f"{body}: {mass} kg"
        inertia = model.body(body).inertia
        assert np.all(inertia > 0) and np.all(inertia < 1e-4)  # from the geoms, not padded


def test_home_keyframe(scene):
    _, model = scene
    key = model.key("home")
    np.testing.assert_allclose(key.qpos[:16], START_ARM_POSE)
    assert key.qpos[16 + 1] < 0 < key.qpos[23 + 1]  # peg right, socket left
    np.testing.assert_allclose(key.qpos[[18, 25]], [PEG_REST_Z, SOCKET_REST_Z])
    np.testing.assert_allclose(key.qpos[19:23], [1, 0, 0, 0])
    np.testing.assert_allclose(key.qpos[26:30], [1, 0, 0, 0])


def test_objects_rest_still_on_the_table(scene):
    _, model = scene
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    start = data.qpos[16:].copy()
    mujoco.mj_step(model, data, 500)  # 1 s
    assert np.abs(data.qpos[16:19] - start[0:3]).max() < 5e-4
    assert np.abs(data.qpos[23:26] - start[7:10]).max() < 5e-4
    assert np.abs(data.qvel[16:]).max() < 1e-3
    # the resting contacts list the (box) objects before the (mesh) table
    table = model.geom("table").id
    pairs = {(int(data.contact.geom1[i]), int(data.contact.geom2[i])) for i in range(data.ncon)}
    assert (model.geom("peg").id, table) in pairs
    assert (model.geom("socket-1").id, table) in pairs
    assert all(g2 == table for _, g2 in pairs)  # nothing else touches
    assert [w.number for w in data.warning] == [0] * len(data.warning)
