"""Base groups: immobile (pose fixed), mocap (teleported), free joint (qpos), on a toy arm."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.base_group import (
    FreeJointRobotBaseGroup,
    ImmobileRobotBaseGroup,
    MocapRobotBaseGroup,
    RobotBaseGroup,
)
from trossen_arm_mujoco.robot.frames import pose7_to_transform
from trossen_arm_mujoco.robot.move_group import MoveGroup

BASE_POSE = pose7_to_transform([0.1, -0.2, 0.3, 0.9238795, 0, 0, 0.3826834])
NEW_POSE = pose7_to_transform([0.5, 0.4, 0.2, 0.7071068, 0, 0.7071068, 0])


@pytest.fixture
def make(toy):
    def build(base: str):
        model = toy.model(base)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        return model, data

    return build


def link3_pose(model, data) -> np.ndarray:
    body = model.body("link3").id
    out = np.eye(4)
    out[:3, :3] = data.xmat[body].reshape(3, 3)
    out[:3, 3] = data.xpos[body]
    return out


def test_base_groups_are_move_groups():
    for kind in (ImmobileRobotBaseGroup, MocapRobotBaseGroup, FreeJointRobotBaseGroup):
        assert issubclass(kind, RobotBaseGroup) and issubclass(kind, MoveGroup)


def test_immobile_base_of_the_kit():
    kit = mujoco.MjModel.from_xml_path(f"{ASSETS_DIR}/stationary_ai/trossen_ai_scene_joint.xml")
    data = mujoco.MjData(kit)
    mujoco.mj_kinematics(kit, data)
    base = ImmobileRobotBaseGroup(kit, "left_base", "left/base_link")
    assert base.n_joints == 0 and base.ctrl_dim == 0
    np.testing.assert_allclose(
        base.get_pose(data), [-0.019982, 0.4575, 0.039086, 0.707107, 0, 0, -0.707107], atol=1e-6
    )
    with pytest.raises(UserError, match="unknown body"):
        ImmobileRobotBaseGroup(kit, "b", "base")


def test_immobile_base(make):
    model, data = make("fixed")
    base = ImmobileRobotBaseGroup(data, "base", "base")
    assert base.n_joints == base.ctrl_dim == base.n_actuators == 0
    np.testing.assert_allclose(base.pose, BASE_POSE, atol=1e-7)
    np.testing.assert_array_equal(base.leaf_frame_to_world, base.pose)
    np.testing.assert_array_equal(base.root_frame_to_world, base.pose)
    np.testing.assert_allclose(base.leaf_frame_to_robot, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(base.get_pose(data)[:3], [0.1, -0.2, 0.3], atol=1e-12)
    assert base.noop_ctrl.shape == (0,) and base.joint_pos.shape == (0,)
    np.testing.assert_array_equal(base.get_jacobian(), np.zeros((6, model.nv)))
    with pytest.raises(UserError, match=r"immobile base .* cannot be set.*mocap_base") as err:
        base.pose = NEW_POSE
    assert "\n" not in str(err.value)


def test_immobile_base_must_be_fixed_to_the_world(make):
    model, data = make("free")
    with pytest.raises(UserError, match="moves with the joints of body 'base'"):
        ImmobileRobotBaseGroup(data, "base", "base")
    with pytest.raises(UserError, match="base body 'link2' moves with the joints of body 'link2'"):
        ImmobileRobotBaseGroup(data, "base", "link2")
    model, data = make("mocap")
    with pytest.raises(UserError, match="is a mocap body; use a mocap base"):
        ImmobileRobotBaseGroup(data, "base", "base")


def test_mocap_base_is_teleported(make):
    model, data = make("mocap")
    base = MocapRobotBaseGroup(data, "base", "base")
    np.testing.assert_allclose(base.pose, BASE_POSE, atol=1e-7)
    before = np.linalg.inv(base.pose) @ link3_pose(model, data)
    base.pose = NEW_POSE
    np.testing.assert_allclose(data.mocap_pos[0], NEW_POSE[:3, 3], atol=1e-12)
    np.testing.assert_allclose(base.pose, NEW_POSE, atol=1e-12)
    mujoco.mj_kinematics(model, data)
    after = np.linalg.inv(base.pose) @ link3_pose(model, data)
    np.testing.assert_allclose(after, before, atol=1e-12)  # the arm came along
    np.testing.assert_allclose(
        link3_pose(model, data)[:3, 3], (NEW_POSE @ before)[:3, 3], atol=1e-12
    )
    base.pose = [1.0, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0]  # 7 values work too
    np.testing.assert_allclose(base.get_pose(data), [1, 2, 3, 1, 0, 0, 0], atol=1e-12)
    with pytest.raises(UserError, match="base pose: .*not a rotation matrix"):
        base.pose = np.diag([2.0, 1.0, 1.0, 1.0])
    model, data = make("fixed")
    with pytest.raises(UserError, match="'base' is not a mocap body"):
        MocapRobotBaseGroup(data, "base", "base")


def test_free_joint_base(make):
    model, data = make("free")
    base = FreeJointRobotBaseGroup(data, "base", "base_free")
    assert base.n_joints == 1 and (base.pos_dim, base.vel_dim) == (7, 6)
    np.testing.assert_array_equal(base.joint_posadr, np.arange(7))
    np.testing.assert_array_equal(base.joint_veladr, np.arange(6))
    assert base.body_id == model.body("base").id
    np.testing.assert_allclose(base.pose, BASE_POSE, atol=1e-7)
    assert np.all(np.isinf(base.joint_pos_limits))
    base.pose = NEW_POSE
    np.testing.assert_allclose(data.qpos[:3], NEW_POSE[:3, 3], atol=1e-12)
    np.testing.assert_allclose(base.pose, NEW_POSE, atol=1e-12)
    mujoco.mj_forward(model, data)
    expected = np.zeros((6, model.nv))
    mujoco.mj_jacBody(model, data, expected[:3], expected[3:], base.body_id)
    np.testing.assert_array_equal(base.get_jacobian(), expected)
    assert np.abs(expected[:, :6]).max() > 0.5 and not expected[:, 6:].any()
    with pytest.raises(UserError, match="'j1' is not a free joint"):
        FreeJointRobotBaseGroup(data, "base", "j1")
    with pytest.raises(UserError, match="expected 7 joint values"):
        base.joint_pos = np.zeros(6)


def test_plain_groups_reject_free_joints(make):
    model, data = make("free")
    with pytest.raises(UserError, match="'base_free' of move group 'x' is not a hinge or slide"):
        MoveGroup(data, "x", ["base_free"])
