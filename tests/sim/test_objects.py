"""Free-joint objects, and the cube's physical plausibility in both kit scenes."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.objects import FreeJointObject

ASSETS = Path(ASSETS_DIR)
KIT_SCENES = ["stationary_ai/trossen_ai_scene.xml", "stationary_ai/trossen_ai_scene_joint.xml"]
TABLE_TOP = 0.02


@pytest.fixture(params=KIT_SCENES)
def scene(request):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / request.param))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


def test_cube_mass_and_inertia_are_plausible(scene):
    model, _ = scene
    geom = model.geom("red_box")
    body = model.body(int(geom.bodyid[0]))
    assert geom.type[0] == mujoco.mjtGeom.mjGEOM_BOX
    side = 2 * geom.size
    np.testing.assert_allclose(side, 0.025)  # a 25 mm cube
    mass = body.mass[0]
    assert 0.01 <= mass <= 0.2
    # solid cube: I = m a^2 / 6 about every axis
    np.testing.assert_allclose(body.inertia, mass * side[0] ** 2 / 6, rtol=0.05)
    assert 100 < mass / side.prod() < 5000  # density between foam and metal (kg/m^3)


def test_cube_starts_resting_on_the_table(scene):
    model, data = scene
    cube = FreeJointObject(model, "red_box_joint", "red_box")
    start = cube.get_pose(data)
    np.testing.assert_allclose(start[2], TABLE_TOP + 0.0125, atol=1e-9)
    lowest = start[2]
    for _ in range(int(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        lowest = min(lowest, data.qpos[cube.qpos_adr + 2])
    end = cube.get_pose(data)
    assert start[2] - lowest < 1e-3  # no drop
    np.testing.assert_allclose(end[:3], start[:3], atol=1e-3)
    assert np.linalg.norm(cube.get_velocity(data)) < 1e-2
    assert [w.number for w in data.warning] == [0] * len(data.warning)


def test_cube_rests_anywhere_in_the_spawn_region(scene):
    model, data = scene
    cube = FreeJointObject(model, "red_box_joint")
    for xy in ([-0.15, -0.2], [0.15, 0.1], [0.05, -0.05]):
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        cube.set_pose(data, [*xy, TABLE_TOP + 0.0125, 1, 0, 0, 0])
        mujoco.mj_step(model, data, 250)  # 0.5 s
        np.testing.assert_allclose(cube.get_pose(data)[:3], [*xy, 0.0325], atol=1e-3)


def test_free_joint_object_pose_roundtrip(scene):
    model, data = scene
    cube = FreeJointObject(model, "red_box_joint", "red_box")
    assert cube.qpos_adr == 16 and cube.dof_adr == 16
    assert cube.body_id == model.body("box").id
    assert cube.geom_id == model.geom("red_box").id
    data.qvel[16:22] = 1.0
    cube.set_pose(data, [0.1, -0.1, 0.2, 2.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(cube.get_pose(data), [0.1, -0.1, 0.2, 1, 0, 0, 0])  # normalised
    np.testing.assert_array_equal(cube.get_velocity(data), 0.0)
    pose = cube.get_pose(data)
    pose[0] = 5.0  # a copy
    assert data.qpos[16] == pytest.approx(0.1)


def test_free_joint_object_errors(scene):
    model, data = scene
    with pytest.raises(UserError, match="not a free joint"):
        FreeJointObject(model, "left/joint_0")
    with pytest.raises(UserError, match="unknown joint 'cube_joint'.*red_box_joint"):
        FreeJointObject(model, "cube_joint")
    with pytest.raises(UserError, match="unknown geom 'cube'.*red_box"):
        FreeJointObject(model, "red_box_joint", "cube")
    # an object is (free joint, geom): the body's name in the geom's place, or a geom of
    # another body, names the body's own geoms
    body = mujoco.mj_id2name(
        model, mujoco.mjtObj.mjOBJ_BODY, model.jnt_bodyid[model.joint("red_box_joint").id]
    )
    with pytest.raises(UserError, match=f"'{body}' is a body, not a geom.*red_box"):
        FreeJointObject(model, "red_box_joint", body)
    with pytest.raises(UserError, match="geom 'table' is not on body"):
        FreeJointObject(model, "red_box_joint", "table")
    cube = FreeJointObject(model, "red_box_joint")
    before = data.qpos.copy()
    with pytest.raises(UserError, match="7 finite values"):
        cube.set_pose(data, [0, 0, 0.1])
    with pytest.raises(UserError, match="7 finite values"):
        cube.set_pose(data, [0, 0, np.nan, 1, 0, 0, 0])
    np.testing.assert_array_equal(data.qpos, before)


def test_zero_quaternion_is_rejected(scene):
    model, data = scene
    cube = FreeJointObject(model, "red_box_joint")
    with pytest.raises(UserError, match="red_box_joint"):
        cube.set_pose(data, [0, 0, 0.1, 0, 0, 0, 0])
    assert np.all(np.isfinite(data.qpos))
