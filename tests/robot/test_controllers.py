"""Controllers reach their targets when a MujocoEnv steps them (single arm and the kit)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.robot.configs import (
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.controllers import (
    CONTROLLERS,
    EEDeltaController,
    EEPoseController,
    JointPosController,
    JointRelPosController,
    make_controller,
)
from trossen_arm_mujoco.robot.kinematics import orientation_error
from trossen_arm_mujoco.sim.env import MujocoEnv

ASSETS = Path(ASSETS_DIR)
WXAI = ASSETS / "wxai/wxai_follower.xml"
KIT_MOCAP = ASSETS / "stationary_ai/trossen_ai_scene.xml"
KIT_JOINT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"
CTRL_DT = 0.02
TWO_SECONDS = int(2.0 / CTRL_DT)


def wxai_env(mode: str) -> MujocoEnv:
    env = MujocoEnv(WXAI, robots={"wxai": wxai_config(mode)}, ctrl_dt=CTRL_DT)
    env.reset()
    return env


def test_joint_position_reaches_target():
    env = wxai_env("joint_position")
    robot = env.robots["wxai"]
    target = np.array([0.5, 0.8, 0.6, -0.3, 0.4, 1.0])
    robot.update_control({"arm": target, "gripper": [0.01]})
    env.step(TWO_SECONDS)
    arm, grip = robot.view.group("arm"), robot.view.group("gripper")
    np.testing.assert_allclose(arm.get_qpos(env.data), target, atol=1e-2)
    np.testing.assert_allclose(grip.get_qpos(env.data), [0.01, 0.01], atol=1e-3)  # coupled
    np.testing.assert_allclose(arm.get_qvel(env.data), 0.0, atol=1e-2)
    assert env.warnings() == []


def test_joint_position_clips_to_limits():
    env = wxai_env("joint_position")
    robot = env.robots["wxai"]
    robot.update_control({"arm": [0, -1.0, 0, 0, 0, 0]})  # joint_1 lower limit is 0
    out = robot.compute_control(env.data)
    assert out["arm"][1] == 0.0


def test_joint_rel_position_reaches_target_once():
    """A relative command is relative to the joints when it is applied, and then held:
    it must not be added again at every control tick."""
    env = wxai_env("joint_rel_position")
    robot = env.robots["wxai"]
    arm = robot.view.group("arm")
    q0 = arm.get_qpos(env.data)
    delta = np.array([0.3, 0.2, 0.3, -0.2, 0.3, 0.5])
    robot.update_control({"arm": delta})
    env.step(TWO_SECONDS)
    np.testing.assert_allclose(arm.get_qpos(env.data), q0 + delta, atol=1e-2)
    # a second command starts from where the arm is now
    robot.update_control({"arm": -delta})
    env.step(TWO_SECONDS)
    np.testing.assert_allclose(arm.get_qpos(env.data), q0, atol=1e-2)


def test_joint_rel_position_limits():
    env = wxai_env("joint_rel_position")
    ctrl = env.robots["wxai"].controllers["arm"]
    assert isinstance(ctrl, JointRelPosController)
    low, high = ctrl.command_limits()
    np.testing.assert_allclose(high, -low)
    np.testing.assert_allclose(high[1], 3.14159)
    out = ctrl.compute(env.data, [0, -5, 0, 0, 0, 0])
    assert out[1] == 0.0  # clipped at the joint limit


def test_ee_delta_moves_tool_frame_in_commanded_direction():
    env = wxai_env("ee_delta")
    robot = env.robots["wxai"]
    arm = robot.view.group("arm")
    for delta in (np.array([0.02, 0.0, 0.0]), np.array([0.0, -0.02, 0.0]), [0.0, 0.0, 0.02]):
        p0 = arm.get_frame_pose(env.data)[:3]
        robot.update_control({"arm": delta})
        env.step(50)
        moved = arm.get_frame_pose(env.data)[:3] - p0
        cos = moved @ delta / (np.linalg.norm(moved) * np.linalg.norm(delta))
        assert cos > 0.95, (delta, moved)
        np.testing.assert_allclose(np.linalg.norm(moved), 0.02, atol=4e-3)


def test_ee_delta_with_rotation():
    env = MujocoEnv(WXAI, robots={"wxai": wxai_config()}, ctrl_dt=CTRL_DT)
    env.reset()
    arm = env.robots["wxai"].view.group("arm")
    ctrl = EEDeltaController(arm, env.model, rotation=True)
    assert ctrl.command_dim == 6
    low, high = ctrl.command_limits()
    np.testing.assert_allclose(high, [0.05, 0.05, 0.05, 0.2, 0.2, 0.2])
    mujoco.mj_forward(env.model, env.data)
    pose0 = arm.get_frame_pose(env.data)
    q = ctrl.compute(env.data, [0, 0, 0, 0.1, 0, 0])
    env.data.qpos[arm.qpos_idx] = q
    mujoco.mj_kinematics(env.model, env.data)
    pose1 = arm.get_frame_pose(env.data)
    np.testing.assert_allclose(orientation_error(pose1[3:], pose0[3:]), [0.1, 0, 0], atol=1e-2)
    with pytest.raises(UserError, match="expected 6 values"):
        ctrl.compute(env.data, [0.01, 0, 0])


def test_ee_pose_mocap_kit_reaches_target():
    env = MujocoEnv(KIT_MOCAP, robots={"kit": stationary_ai_mocap_config()}, ctrl_dt=CTRL_DT)
    env.reset()
    robot = env.robots["kit"]
    assert isinstance(robot.controllers["left_arm"], EEPoseController)
    arm = robot.view.group("left_arm")
    p0 = arm.get_frame_pose(env.data)
    quat = (Quaternion(axis=[0, 1, 0], degrees=20) * Quaternion(p0[3:])).elements
    target = np.concatenate([p0[:3] + [0.05, -0.03, 0.04], quat])
    robot.update_control({"left_arm": target})
    env.step(TWO_SECONDS // 2)
    pose = arm.get_frame_pose(env.data)
    np.testing.assert_allclose(pose[:3], target[:3], atol=2e-3)
    assert np.linalg.norm(orientation_error(target[3:], pose[3:])) < 1e-2
    # the other arm did not move
    right = robot.view.group("right_arm")
    np.testing.assert_allclose(
        right.get_qpos(env.data), [0, np.pi / 12, np.pi / 12, 0, 0, 0], atol=1e-3
    )
    assert env.warnings() == []


def test_ee_pose_ik_on_joint_kit_reaches_target():
    config = stationary_ai_joint_config().with_command_modes(right_arm="ee_pose")
    env = MujocoEnv(KIT_JOINT, robots={"kit": config}, ctrl_dt=CTRL_DT)
    env.reset()
    robot = env.robots["kit"]
    arm = robot.view.group("right_arm")
    p0 = arm.get_frame_pose(env.data)
    quat = (Quaternion(axis=[0, 0, 1], degrees=-15) * Quaternion(p0[3:])).elements
    target = np.concatenate([p0[:3] + [0.05, 0.03, 0.04], quat])
    robot.update_control({"right_arm": target})
    env.step(TWO_SECONDS)
    pose = arm.get_frame_pose(env.data)
    np.testing.assert_allclose(pose[:3], target[:3], atol=3e-3)
    assert np.linalg.norm(orientation_error(target[3:], pose[3:])) < 2e-2


def test_controller_registry_and_errors():
    assert set(CONTROLLERS) == {"joint_position", "joint_rel_position", "ee_pose", "ee_delta"}
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    view = wxai_config().build_view(model)
    with pytest.raises(UserError, match="unknown command mode 'velocity'.*ee_delta"):
        make_controller("velocity", view.group("arm"), model)
    with pytest.raises(UserError, match="needs joint actuators"):
        JointPosController(view.group("base"), model)
    with pytest.raises(UserError, match="needs a tool frame"):
        EEPoseController(view.group("gripper"), model)
    with pytest.raises(UserError, match="joint-actuated arm"):
        EEDeltaController(view.group("gripper"), model)
    mocap_model = mujoco.MjModel.from_xml_path(str(KIT_MOCAP))
    mocap_view = stationary_ai_mocap_config().build_view(mocap_model)
    with pytest.raises(UserError, match="joint_position needs joint actuators"):
        make_controller("joint_position", mocap_view.group("left_arm"), mocap_model)
    with pytest.raises(UserError, match="joint-actuated arm"):
        make_controller("ee_delta", mocap_view.group("left_arm"), mocap_model)


def test_command_checks():
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    data = mujoco.MjData(model)
    view = wxai_config().build_view(model)
    ctrl = make_controller("joint_position", view.group("arm"), model)
    assert ctrl.command_dim == 6
    with pytest.raises(UserError, match=r"arm \(joint_position\): expected 6 values, got 5"):
        ctrl.compute(data, np.zeros(5))
    with pytest.raises(UserError, match="NaN or inf"):
        ctrl.compute(data, [0, 0, 0, np.nan, 0, 0])
    pose = make_controller("ee_pose", view.group("arm"), model)
    assert pose.command_dim == 7
    with pytest.raises(UserError, match="expected 7 values"):
        pose.compute(data, np.zeros(3))
