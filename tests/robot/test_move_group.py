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


# -- the data-bound interface --------------------------------------------------------------


def toy_arm(model_or_data, frame: str = "tool", frame_type: str = "site") -> ArmMoveGroup:
    return ArmMoveGroup(
        model_or_data, "arm", ["j1", "j2", "j3"], ["a1", "a2", "a3"], frame, frame_type
    )


def test_bound_state_properties(toy_model):
    data = mujoco.MjData(toy_model)
    arm = toy_arm(data)
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


def test_limits(toy_model):
    arm = toy_arm(toy_model)
    limits = arm.joint_pos_limits
    assert limits.shape == (3, 2)
    np.testing.assert_array_equal(limits, [[-2, 2], [-np.inf, np.inf], [0, 0.1]])  # j2 unlimited
    ctrl = arm.ctrl_limits
    assert ctrl.shape == (3, 2)
    np.testing.assert_array_equal(ctrl[:, 0], [-2, -3, 0])
    np.testing.assert_array_equal(ctrl[:, 1], [2, 3, 0.1])
    low, high = arm.ctrl_limits()  # the earlier call form
    np.testing.assert_array_equal(low, [-2, -3, 0])
    np.testing.assert_array_equal(high, [2, 3, 0.1])
    assert type(ctrl[:, 0]) is np.ndarray and type(ctrl + 1) is np.ndarray
    arm.ctrl_limits[0, 0] = 99.0  # a fresh copy every time: the group is unchanged
    assert arm.ctrl_limits[0, 0] == -2


def test_unbound_group_says_how_to_bind(toy_model):
    arm = toy_arm(toy_model)
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


def test_frames_are_the_mujoco_frames(toy_model):
    data = mujoco.MjData(toy_model)
    arm = toy_arm(data)
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


def test_frames_relative_to_the_robot_base(toy_model):
    from trossen_arm_mujoco.robot.base_group import ImmobileRobotBaseGroup

    data = mujoco.MjData(toy_model)
    arm = toy_arm(data)
    arm.robot_base_group = ImmobileRobotBaseGroup(data, "base", "base")
    arm.joint_pos = [0.4, -0.7, 0.03]
    mujoco.mj_kinematics(toy_model, data)
    base = arm.robot_base_group.pose
    np.testing.assert_allclose(base[:3, 3], [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(
        arm.leaf_frame_to_robot, np.linalg.inv(base) @ arm.leaf_frame_to_world, atol=1e-12
    )
    np.testing.assert_allclose(arm.root_frame_to_robot, np.eye(4), atol=1e-12)  # root = base


@pytest.mark.parametrize(("frame", "frame_type"), [("tool", "site"), ("link3", "body")])
def test_get_jacobian_matches_finite_differences(toy_model, frame, frame_type):
    """Both the linear and the angular rows, for a site and a body leaf frame."""
    data = mujoco.MjData(toy_model)
    arm = toy_arm(data, frame, frame_type)
    assert arm.leaf_frame_type == frame_type
    q0 = np.array([0.4, -0.7, 0.03])
    arm.joint_pos = q0
    mujoco.mj_forward(toy_model, data)
    jac = arm.get_jacobian()
    assert jac.shape == (6, toy_model.nv)
    eps = 1e-6
    for j in range(3):
        poses = []
        for sign in (1, -1):
            q = q0.copy()
            q[j] += sign * eps
            arm.joint_pos = q
            mujoco.mj_kinematics(toy_model, data)
            poses.append(arm.leaf_frame_to_world)
        lin = (poses[0][:3, 3] - poses[1][:3, 3]) / (2 * eps)
        rot = poses[0][:3, :3] @ poses[1][:3, :3].T
        ang = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]]) / 2
        np.testing.assert_allclose(jac[:3, j], lin, atol=1e-7)
        np.testing.assert_allclose(jac[3:, j], ang / (2 * eps), atol=1e-7)
    np.testing.assert_array_equal(jac[:, 3:], 0.0)  # the fingers do not move the frame


def test_mjcf_frame_mixin_site_and_body(toy_model):
    data = mujoco.MjData(toy_model)
    body_frame = toy_arm(data, "link3", "body")
    assert body_frame.leaf_frame_id == toy_model.body("link3").id
    mujoco.mj_kinematics(toy_model, data)
    np.testing.assert_array_equal(
        body_frame.get_frame_position(data), data.xpos[body_frame.leaf_frame_id]
    )
    np.testing.assert_array_equal(
        body_frame.get_frame_pose(data)[3:], data.xquat[body_frame.leaf_frame_id]
    )
    assert body_frame.frame_site_id == -1 and body_frame.frame_site_name == ""
    from trossen_arm_mujoco.robot.controllers import EEDeltaController

    with pytest.raises(UserError, match="IK needs a site as the tool frame"):
        EEDeltaController(body_frame, toy_model)
    assert toy_arm(data).frame_site_id == toy_model.site("tool").id
    with pytest.raises(UserError, match="must be 'site' or 'body'"):
        toy_arm(data, "tool", "geom")
    with pytest.raises(UserError, match="unknown body 'tool'"):
        toy_arm(data, "tool", "body")


def test_wxai_tool_frame_agrees_with_the_fk_reference(wxai):
    import json

    fk = json.loads((Path(__file__).parents[1] / "fixtures" / "fk_reference.json").read_text())
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(data, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    for k in range(len(fk["config"])):
        data.qpos[:] = fk["config"][k]
        mujoco.mj_kinematics(wxai, data)
        leaf = arm.leaf_frame_to_world
        np.testing.assert_allclose(leaf[:3, 3], fk["ee_pos"][k], atol=1e-6)
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, leaf[:3, :3].reshape(9))
        ref = np.asarray(fk["ee_quat"][k])
        assert min(np.abs(quat - ref).max(), np.abs(quat + ref).max()) < 1e-6
