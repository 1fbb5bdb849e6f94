"""Move groups: indices looked up once, qpos/ctrl access, validation of what is written."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.move_group import (
    ArmMoveGroup,
    GripperGroup,
    ImmobileBaseGroup,
    MocapArmGroup,
    MoveGroup,
    SimplyActuatedMoveGroup,
)

ASSETS = Path(ASSETS_DIR)
ARM_JOINTS = [f"joint_{i}" for i in range(6)]
FINGERS = ["right_carriage_joint", "left_carriage_joint"]


@pytest.fixture(scope="module")
def wxai():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    return model


@pytest.fixture(scope="module")
def kit_joint():
    return mujoco.MjModel.from_xml_path(str(ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"))


@pytest.fixture(scope="module")
def kit_mocap():
    return mujoco.MjModel.from_xml_path(str(ASSETS / "stationary_ai/trossen_ai_scene.xml"))


def test_move_group_indices(kit_joint):
    right = MoveGroup(kit_joint, "right_arm", [f"right/{j}" for j in ARM_JOINTS])
    assert right.n_joints == 6 and right.ctrl_dim == 0
    np.testing.assert_array_equal(right.qpos_idx, np.arange(8, 14))
    np.testing.assert_array_equal(right.dof_idx, np.arange(8, 14))
    np.testing.assert_allclose(right.joint_range[1], [0.0, 3.14159])
    np.testing.assert_allclose(right.joint_range[2], [0.0, 2.35619])


def test_unknown_joint_lists_valid_names(kit_joint):
    with pytest.raises(UserError) as err:
        MoveGroup(kit_joint, "arm", ["left/joint_9"])
    msg = str(err.value)
    assert "unknown joint 'left/joint_9'" in msg
    assert "left/joint_0" in msg and "red_box_joint" in msg


def test_free_joint_rejected(kit_joint):
    with pytest.raises(UserError, match="not a hinge or slide"):
        MoveGroup(kit_joint, "box", ["red_box_joint"])


def test_qpos_qvel_access_and_validation(wxai):
    data = mujoco.MjData(wxai)
    arm = MoveGroup(wxai, "arm", ARM_JOINTS)
    q = np.array([0.1, 0.2, 0.3, -0.4, 0.5, -0.6])
    arm.set_qpos(data, q)
    np.testing.assert_array_equal(data.qpos[:6], q)
    got = arm.get_qpos(data)
    got[:] = 0  # a copy, not a view
    np.testing.assert_array_equal(data.qpos[:6], q)
    data.qvel[:6] = np.arange(6)
    np.testing.assert_array_equal(arm.get_qvel(data), np.arange(6))
    with pytest.raises(UserError, match="expected 6 joint values"):
        arm.set_qpos(data, q[:5])
    with pytest.raises(UserError, match="NaN"):
        arm.set_qpos(data, [0, 0, np.nan, 0, 0, 0])
    np.testing.assert_array_equal(data.qpos[:6], q)  # nothing written on error


def test_plain_group_takes_no_control(wxai):
    data = mujoco.MjData(wxai)
    arm = MoveGroup(wxai, "arm", ARM_JOINTS)
    arm.set_ctrl(data, [])
    with pytest.raises(UserError, match="takes no control"):
        arm.set_ctrl(data, [1.0])
    assert arm.get_ctrl(data).shape == (0,)
    low, high = arm.ctrl_limits()
    assert low.shape == high.shape == (0,)


def test_simply_actuated_group(wxai):
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    assert isinstance(arm, SimplyActuatedMoveGroup)
    assert arm.ctrl_dim == 6
    low, high = arm.ctrl_limits()
    np.testing.assert_allclose(low, arm.joint_range[:, 0])  # inheritrange="1"
    np.testing.assert_allclose(high, arm.joint_range[:, 1])
    arm.set_ctrl(data, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    np.testing.assert_allclose(arm.get_ctrl(data), [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    arm.set_ctrl(data, [10, 10, 10, 10, 10, 10])  # clipped to the actuator range
    np.testing.assert_allclose(arm.get_ctrl(data), high)
    with pytest.raises(UserError, match="NaN"):
        arm.set_ctrl(data, [np.inf, 0, 0, 0, 0, 0])
    with pytest.raises((UserError, ValueError)):  # wrong length never gets written
        arm.set_ctrl(data, [0.0, 0.0])
    data.qpos[:6] = [0.3, 0.2, 0.1, 0.0, -0.1, -0.2]
    np.testing.assert_array_equal(arm.get_noop_ctrl(data), data.qpos[:6])


def test_one_actuator_per_joint_required(wxai):
    with pytest.raises(UserError, match="one actuator per joint"):
        SimplyActuatedMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS[:5])
    with pytest.raises(UserError, match="unknown actuator 'motor'.*valid actuators"):
        SimplyActuatedMoveGroup(wxai, "arm", ARM_JOINTS[:1], ["motor"])


def test_frame_pose_and_unknown_site(wxai):
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    mujoco.mj_kinematics(wxai, data)
    np.testing.assert_allclose(arm.get_frame_pose(data), [0.2537, 0, 0.1635, 1, 0, 0, 0], atol=1e-9)
    with pytest.raises(UserError, match="unknown site 'tool'.*ee_site"):
        ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "tool")


def test_gripper_group(kit_joint):
    data = mujoco.MjData(kit_joint)
    grip = GripperGroup(kit_joint, "left_gripper", [f"left/{f}" for f in FINGERS], "left/gripper")
    assert grip.ctrl_dim == 1 and grip.n_joints == 2
    assert grip.actuated_qpos_idx == 7  # the left carriage carries the actuator
    np.testing.assert_allclose(grip.ctrl_limits(), ([0.0], [0.044]))
    grip.set_ctrl(data, [0.02])
    np.testing.assert_allclose(grip.get_ctrl(data), [0.02])
    grip.set_ctrl(data, [0.5])
    np.testing.assert_allclose(grip.get_ctrl(data), [0.044])
    data.qpos[7] = 0.031
    np.testing.assert_allclose(grip.get_noop_ctrl(data), [0.031])
    with pytest.raises(UserError, match="NaN"):
        grip.set_ctrl(data, [np.nan])
    with pytest.raises(UserError, match="drives none of"):
        GripperGroup(kit_joint, "bad", [f"left/{f}" for f in FINGERS], "right/gripper")


def test_mocap_arm_group(kit_mocap):
    data = mujoco.MjData(kit_mocap)
    arm = MocapArmGroup(
        kit_mocap, "right_arm", [f"right/{j}" for j in ARM_JOINTS], "mocap_right", "right/ee_site"
    )
    assert arm.ctrl_dim == 7 and arm.mocap_id == 1
    arm.set_ctrl(data, [0.1, -0.2, 0.3, 2.0, 0.0, 0.0, 0.0])  # quaternion gets normalised
    np.testing.assert_allclose(data.mocap_pos[1], [0.1, -0.2, 0.3])
    np.testing.assert_allclose(data.mocap_quat[1], [1, 0, 0, 0])
    np.testing.assert_allclose(arm.get_ctrl(data), [0.1, -0.2, 0.3, 1, 0, 0, 0])
    np.testing.assert_allclose(arm.get_noop_ctrl(data), arm.get_ctrl(data))
    with pytest.raises(UserError, match="zero length"):
        arm.set_ctrl(data, [0, 0, 0, 0, 0, 0, 0])
    with pytest.raises(UserError, match="NaN"):
        arm.set_ctrl(data, [np.nan, 0, 0, 1, 0, 0, 0])
    with pytest.raises(UserError, match="not a mocap body"):
        MocapArmGroup(kit_mocap, "x", [], "right/link_6", "right/ee_site")


def test_immobile_base(kit_joint):
    data = mujoco.MjData(kit_joint)
    mujoco.mj_kinematics(kit_joint, data)
    base = ImmobileBaseGroup(kit_joint, "left_base", "left/base_link")
    assert base.n_joints == 0 and base.ctrl_dim == 0
    np.testing.assert_allclose(
        base.get_pose(data), [-0.019982, 0.4575, 0.039086, 0.707107, 0, 0, -0.707107], atol=1e-6
    )
    with pytest.raises(UserError, match="unknown body"):
        ImmobileBaseGroup(kit_joint, "b", "base")
