"""MoveGroup: joint indices looked up once, qpos/qvel/ctrl access and its validation, the
data-bound properties, limits, and the group's frames (root, leaf, robot)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.base_group import ImmobileRobotBaseGroup
from trossen_arm_mujoco.robot.move_group import MoveGroup

ASSETS = Path(ASSETS_DIR)
ARM_JOINTS = [f"joint_{i}" for i in range(6)]


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
    low, high = arm.ctrl_limits.T
    assert low.shape == high.shape == (0,)


def test_bound_state_properties(toy, toy_model):
    data = mujoco.MjData(toy_model)
    arm = toy.arm(data)
    assert arm.is_bound and arm.data is data and arm.model is toy_model
    np.testing.assert_array_equal(arm.joint_ids, [0, 1, 2])
    np.testing.assert_array_equal(arm.actuator_ids, [0, 1, 2])
    np.testing.assert_array_equal(arm.joint_posadr, [0, 1, 2])
    np.testing.assert_array_equal(arm.joint_veladr, [0, 1, 2])
    assert (arm.pos_dim, arm.vel_dim, arm.n_actuators, arm.ctrl_dim) == (3, 3, 3, 3)
    arm.joint_pos = [0.1, -0.2, 0.05]
    np.testing.assert_array_equal(data.qpos[:3], [0.1, -0.2, 0.05])
    got = arm.joint_pos
    got[:] = 9.0  # a copy
    np.testing.assert_array_equal(arm.joint_pos, [0.1, -0.2, 0.05])
    arm.joint_vel = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(data.qvel[:3], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(arm.joint_vel, [1.0, 2.0, 3.0])
    arm.ctrl = [0.5, 5.0, 0.05]  # clipped to the actuator range
    np.testing.assert_array_equal(data.ctrl[:3], [0.5, 3.0, 0.05])
    np.testing.assert_array_equal(arm.ctrl, [0.5, 3.0, 0.05])
    np.testing.assert_array_equal(arm.noop_ctrl, [0.1, -0.2, 0.05])
    with pytest.raises(UserError, match="expected 3 joint values"):
        arm.joint_pos = [0.0, 0.0]
    with pytest.raises(UserError, match="expected 3 joint velocities"):
        arm.joint_vel = [0.0]
    with pytest.raises(UserError, match="NaN"):
        arm.ctrl = [0.0, np.nan, 0.0]
    np.testing.assert_array_equal(data.qpos[:3], [0.1, -0.2, 0.05])  # nothing written on error


def test_limits(toy, toy_model):
    arm = toy.arm(toy_model)
    limits = arm.joint_pos_limits
    assert limits.shape == (3, 2)
    np.testing.assert_array_equal(limits, [[-2, 2], [-np.inf, np.inf], [0, 0.1]])  # j2 unlimited
    ctrl = arm.ctrl_limits
    assert ctrl.shape == (3, 2)
    np.testing.assert_array_equal(ctrl[:, 0], [-2, -3, 0])
    np.testing.assert_array_equal(ctrl[:, 1], [2, 3, 0.1])
    with pytest.raises(TypeError):
        arm.ctrl_limits()  # a plain array: the earlier call form is gone
    assert type(ctrl[:, 0]) is np.ndarray and type(ctrl + 1) is np.ndarray
    arm.ctrl_limits[0, 0] = 99.0  # a fresh copy every time: the group is unchanged
    assert arm.ctrl_limits[0, 0] == -2


def test_unbound_group_says_how_to_bind(toy, toy_model):
    arm = toy.arm(toy_model)
    assert not arm.is_bound
    with pytest.raises(UserError, match=r"not bound to an MjData.*bind"):
        arm.joint_pos  # noqa: B018
    arm.bind(mujoco.MjData(toy_model))
    assert arm.joint_pos.shape == (3,)
    other = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    with pytest.raises(UserError, match="belongs to another model"):
        arm.bind(mujoco.MjData(other))
    with pytest.raises(UserError, match="expected a mujoco.MjModel or mujoco.MjData"):
        MoveGroup("model.xml", "arm", [])


def body_tf(data, body_id):
    out = np.eye(4)
    out[:3, :3] = data.xmat[body_id].reshape(3, 3)
    out[:3, 3] = data.xpos[body_id]
    return out


def test_frames_are_the_mujoco_frames(toy, toy_model):
    data = mujoco.MjData(toy_model)
    arm = toy.arm(data)
    arm.joint_pos = [0.4, -0.7, 0.03]
    mujoco.mj_kinematics(toy_model, data)
    site = toy_model.site("tool").id
    assert (arm.leaf_frame_type, arm.leaf_frame_id) == ("site", site)
    leaf = arm.leaf_frame_to_world
    np.testing.assert_array_equal(leaf[:3, 3], data.site_xpos[site])
    np.testing.assert_array_equal(leaf[:3, :3], data.site_xmat[site].reshape(3, 3))
    np.testing.assert_array_equal(leaf[3], [0, 0, 0, 1])
    base = toy_model.body("base").id
    assert arm.root_body_id == base  # the parent of j1's body
    np.testing.assert_array_equal(arm.root_frame_to_world, body_tf(data, base))
    np.testing.assert_allclose(
        arm.leaf_frame_to_root, np.linalg.inv(body_tf(data, base)) @ leaf, atol=1e-12
    )
    # no base group: the robot frame is the root frame
    np.testing.assert_array_equal(arm.root_frame_to_robot, np.eye(4))
    np.testing.assert_allclose(arm.leaf_frame_to_robot, arm.leaf_frame_to_root, atol=1e-15)
    # a plain group's leaf frame is the body of its last joint
    plain = MoveGroup(data, "two", ["j1", "j2"])
    assert (plain.leaf_frame_type, plain.leaf_frame_id) == ("body", toy_model.body("link2").id)
    np.testing.assert_array_equal(plain.leaf_frame_to_world, body_tf(data, plain.leaf_frame_id))


def test_frames_relative_to_the_robot_base(toy, toy_model):
    data = mujoco.MjData(toy_model)
    arm = toy.arm(data)
    arm.robot_base_group = ImmobileRobotBaseGroup(data, "base", "base")
    arm.joint_pos = [0.4, -0.7, 0.03]
    mujoco.mj_kinematics(toy_model, data)
    base = arm.robot_base_group.pose
    np.testing.assert_allclose(base[:3, 3], [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(
        arm.leaf_frame_to_robot, np.linalg.inv(base) @ arm.leaf_frame_to_world, atol=1e-12
    )
    np.testing.assert_allclose(arm.root_frame_to_robot, np.eye(4), atol=1e-12)  # root = base
