"""The vendor's Controller API (``trossen_arm_mujoco.src.controller``) over the robot layer."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.assets import asset_path
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.kinematics import Kinematics
from trossen_arm_mujoco.src.controller import (
    DEFAULT_IK_DAMPING,
    DEFAULT_IK_SCALE,
    Controller,
    RobotType,
)

DOWN = np.array([np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0])


def _scene(path: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(asset_path(path)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


@pytest.fixture
def wxai():
    return _scene("wxai/scene_pick_place.xml")


def test_vendor_import_path_and_members():
    from trossen_arm_mujoco.src import Controller as C2
    from trossen_arm_mujoco.src import RobotType as R2

    assert C2 is Controller and R2 is RobotType
    assert [(m.name, m.value) for m in RobotType] == [
        ("WXAI", "wxai"),
        ("STATIONARY_AI", "stationary_ai"),
        ("MOBILE_AI", "mobile_ai"),
    ]
    assert (DEFAULT_IK_SCALE, DEFAULT_IK_DAMPING) == (0.5, 0.03)


def test_defaults_and_string_robot_type(wxai):
    model, data = wxai
    robot = Controller(model, data, "wxai")
    assert robot.robot_type is RobotType.WXAI
    assert (robot.ik_scale, robot.ik_damping) == (0.5, 0.03)
    assert robot.arm.joint_names == [f"joint_{i}" for i in range(6)]


def test_set_ee_pose_reaches_a_pose_and_returns_the_error(wxai):
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI, ik_scale=1.0)
    target = np.array([0.3, 0.1, 0.12])
    first = robot.set_ee_pose(target, DOWN)
    assert first == pytest.approx(np.linalg.norm(target - data.site_xpos[robot.ee_site_id]))
    for _ in range(1500):
        error = robot.set_ee_pose(target, DOWN)
        mujoco.mj_step(model, data)
    assert error < 1e-3
    _, quat = robot.get_ee_pose()
    assert abs(abs(quat @ DOWN) - 1) < 1e-4


def test_one_step_is_the_damped_least_squares_step(wxai):
    """set_ee_pose's joint targets: q + ik_scale * DLS(J, e), within the joint limits."""
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI, ik_scale=0.5, ik_damping=0.05)
    target = data.site_xpos[robot.ee_site_id] + np.array([0.01, -0.02, 0.0])
    dq = robot.compute_ik_step(target, position_only=True)
    arm = robot.arm
    kin = Kinematics(model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range)
    jac = kin.jacobian(data.qpos)[:3]
    err = target - data.site_xpos[robot.ee_site_id]
    expected = 0.5 * jac.T @ np.linalg.solve(jac @ jac.T + 0.05**2 * np.eye(3), err)
    np.testing.assert_allclose(dq, expected, atol=1e-9)
    assert np.abs(dq).max() > 1e-3


def test_controls_are_rate_limited_by_the_robot_layer(wxai):
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI, ik_scale=1.0)
    before = data.ctrl[robot.arm.actuator_ids].copy()
    robot.set_ee_pose([0.3, -0.2, 0.1], DOWN)
    step = np.abs(data.ctrl[robot.arm.actuator_ids] - before)
    limit = robot.arm.velocity_limits * model.opt.timestep
    assert (step <= limit + 1e-12).all() and step.max() > 0


def test_gripper_open_close(wxai):
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI)
    robot.close_gripper()
    assert data.ctrl[robot.gripper.actuator_id] == pytest.approx(0.0)
    for _ in range(300):
        mujoco.mj_step(model, data)
    assert robot.get_gripper_position() < 0.005
    robot.open_gripper()
    assert data.ctrl[robot.gripper.actuator_id] == pytest.approx(0.044)


def test_out_of_reach_target_keeps_the_last_feasible_pose(wxai, capsys):
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI, ik_scale=1.0)
    feasible = np.array([0.3, 0.05, 0.15])
    for _ in range(600):
        robot.set_ee_pose(feasible, DOWN)
        mujoco.mj_step(model, data)
    held = data.ctrl[robot.arm.actuator_ids].copy()
    pose = data.site_xpos[robot.ee_site_id].copy()
    capsys.readouterr()
    for _ in range(300):
        robot.set_ee_pose([1.5, 0.0, 0.2], DOWN)
        mujoco.mj_step(model, data)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        "note: arm: target [1.5, 0.0, 0.2] m is out of reach"
    )
    assert robot.out_of_reach and robot.out_of_reach_count == 300
    np.testing.assert_allclose(data.ctrl[robot.arm.actuator_ids], held, atol=1e-9)
    assert np.linalg.norm(data.site_xpos[robot.ee_site_id] - pose) < 2e-3
    robot.set_ee_pose(feasible, DOWN)  # back in reach: tracking again
    assert not robot.out_of_reach


def test_stationary_ai_arms_by_site_with_vendor_names():
    model, data = _scene("stationary_ai/trossen_ai_scene_joint.xml")
    left = Controller(
        model,
        data,
        RobotType.STATIONARY_AI,
        ee_site_name="follower_left_ee_site",
        arm_joint_names=[f"follower_left_joint_{i}" for i in range(6)],
        gripper_joint_names=["follower_left_left_carriage_joint"],
    )
    right = Controller(model, data, RobotType.STATIONARY_AI, ee_site_name="right/ee_site")
    assert left.arm.joint_names == [f"left/joint_{i}" for i in range(6)]
    assert right.arm.joint_names == [f"right/joint_{i}" for i in range(6)]
    right_ctrl = data.ctrl[right.arm.actuator_ids].copy()
    for _ in range(400):
        left.set_ee_pose([0.0, 0.2, 0.15], DOWN)
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.site_xpos[left.ee_site_id] - [0.0, 0.2, 0.15]) < 0.01
    np.testing.assert_array_equal(data.ctrl[right.arm.actuator_ids], right_ctrl)


def test_mobile_ai_arm_rides_the_base():
    """A Mobile AI arm by the vendor's site name; its reach is measured from its first joint,
    wherever the base has driven."""
    model, data = _scene("mobile_ai/mobile_ai_scene.xml")
    right = Controller(model, data, "mobile_ai", ee_site_name="follower_right_ee_site")
    assert right.arm.joint_names == [f"right/joint_{i}" for i in range(6)]
    assert right.robot.safety_floor.floor_z == pytest.approx(0.75)
    target = data.site_xpos[right.ee_site_id] + np.array([0.1, 0.05, -0.15])
    for _ in range(600):
        right.set_ee_pose(target, DOWN)
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.site_xpos[right.ee_site_id] - target) < 0.01
    assert not right.out_of_reach


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (
            {"robot_type": "humanoid"},
            "unknown robot type 'humanoid'; valid robot types: RobotType.WXAI",
        ),
        ({"ee_site_name": "tool"}, "unknown end-effector site of WXAI 'tool'; valid"),
        ({"arm_joint_names": ["joint_1", "joint_2"]}, "do not match this arm's joints"),
        ({"robot_type": RobotType.MOBILE_AI}, "unknown end-effector site of MOBILE_AI 'ee_site'"),
    ],
)
def test_bad_arguments_are_one_line(wxai, kwargs, words):
    model, data = wxai
    with pytest.raises(UserError) as info:
        Controller(model, data, **kwargs)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_robot_type_lookup_by_value():
    assert RobotType("stationary_ai") is RobotType.STATIONARY_AI
    with pytest.raises(ValueError, match="unknown robot type 'x'"):
        RobotType("x")


def test_bad_targets(wxai):
    model, data = wxai
    robot = Controller(model, data)
    with pytest.raises(UserError, match="target_position must be 3 finite numbers"):
        robot.set_ee_pose([0.3, np.nan, 0.1])
    with pytest.raises(UserError, match="nonzero quaternion"):
        robot.set_ee_pose([0.3, 0.0, 0.1], [0, 0, 0, 0])


def test_set_arm_joint_positions_leaves_the_arm_going_there_under_plain_mj_step(wxai):
    """As the vendor's: the targets go to the actuators, and mj_step alone takes the arm
    there (no speed-limited single step)."""
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI)
    start = robot.get_arm_joint_positions()
    goal = start + np.array([0.4, 0.3, 0.3, 0.2, 0.2, -0.2])
    robot.set_arm_joint_positions(goal)
    np.testing.assert_allclose(data.ctrl[robot.arm_actuator_ids], goal)
    for _ in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    np.testing.assert_allclose(robot.get_arm_joint_positions(), goal, atol=0.02)
    with pytest.raises(UserError, match="joint_positions must be 6 finite numbers"):
        robot.set_arm_joint_positions([0.0] * 5)


def test_the_vendors_attributes_and_constants(wxai):
    model, data = wxai
    robot = Controller(model, data, RobotType.WXAI)
    assert robot.num_arm_joints == 6 and len(robot.arm_qpos_indices) == 6
    names = [model.joint(j).name for j in robot.arm_joint_ids]
    assert names == [f"joint_{i}" for i in range(6)]
    assert list(robot.arm_dof_indices) == [model.jnt_dofadr[j] for j in robot.arm_joint_ids]
    assert len(robot.arm_actuator_ids) == 6 and len(robot.gripper_actuator_ids) == 1
    assert len(robot.gripper_joint_ids) >= 1 and len(robot.gripper_qpos_indices) >= 1
    assert robot.jac_pos.shape == robot.jac_rot.shape == (3, model.nv)
    robot.compute_ik_step([0.3, 0.0, 0.2])
    assert np.abs(robot.jac_pos).sum() > 0  # filled by the IK step
    assert Controller.GRIPPER_OPEN_POSITION == 0.044
    assert Controller.GRIPPER_CLOSED_POSITION == 0.022
