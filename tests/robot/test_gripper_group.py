"""GripperGroup: open/close by name, the opening between the fingers, is_open."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.gripper_group import GripperGroup

WXAI = Path(ASSETS_DIR) / "wxai/wxai_follower.xml"
KIT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene_joint.xml"
FINGERS = ["right_carriage_joint", "left_carriage_joint"]


def test_kit_gripper_control_is_the_actuated_finger():
    kit = mujoco.MjModel.from_xml_path(str(KIT))
    data = mujoco.MjData(kit)
    grip = GripperGroup(kit, "left_gripper", [f"left/{f}" for f in FINGERS], "left/gripper")
    assert grip.ctrl_dim == 1 and grip.n_joints == 2
    assert grip.actuated_qpos_idx == 7  # the left carriage carries the actuator
    np.testing.assert_allclose(grip.ctrl_limits, [[0.0, 0.044]])
    grip.set_ctrl(data, [0.02])
    np.testing.assert_allclose(grip.get_ctrl(data), [0.02])
    grip.set_ctrl(data, [0.5])
    np.testing.assert_allclose(grip.get_ctrl(data), [0.044])
    data.qpos[7] = 0.031
    np.testing.assert_allclose(grip.get_noop_ctrl(data), [0.031])
    with pytest.raises(UserError, match="NaN"):
        grip.set_ctrl(data, [np.nan])
    with pytest.raises(UserError, match="drives none of"):
        GripperGroup(kit, "bad", [f"left/{f}" for f in FINGERS], "right/gripper")


def test_toy_gripper_open_close_and_distance(toy_model):
    data = mujoco.MjData(toy_model)
    grip = GripperGroup(data, "gripper", ["fa", "fb"], "grip")
    assert grip.n_actuators == 1 and grip.ctrl_dim == 1 and grip.pos_dim == 2
    np.testing.assert_array_equal(grip.actuator_ids, [toy_model.actuator("grip").id])
    grip.set_gripper_ctrl_open(True)
    np.testing.assert_array_equal(grip.ctrl, [0.03])  # top of the actuator range
    grip.set_gripper_ctrl_open(False)
    np.testing.assert_array_equal(grip.ctrl, [0.0])
    assert grip.inter_finger_dist_range == (0.0, pytest.approx(0.06))
    grip.joint_pos = [0.02, 0.02]
    assert grip.inter_finger_dist == pytest.approx(0.04)
    assert grip.is_open
    grip.joint_pos = [0.01, 0.01]
    assert grip.inter_finger_dist == pytest.approx(0.02)
    assert not grip.is_open
    np.testing.assert_array_equal(grip.noop_ctrl, [0.01])  # holds the actuated finger


def test_custom_open_and_closed_controls(toy_model):
    data = mujoco.MjData(toy_model)
    grip = GripperGroup(data, "g", ["fa", "fb"], "grip", open_ctrl=0.025, closed_ctrl=0.005)
    grip.set_gripper_ctrl_open(True)
    np.testing.assert_array_equal(data.ctrl[3], 0.025)
    grip.set_gripper_ctrl_open(False)
    np.testing.assert_array_equal(data.ctrl[3], 0.005)


def test_wxai_gripper_distance_is_the_pad_gap():
    """On the wxai the pads touch at 0 and the gap is about 2 q (the robot facts)."""
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    data = mujoco.MjData(model)
    grip = GripperGroup(data, "gripper", ["right_carriage_joint", "left_carriage_joint"], "gripper")
    assert grip.inter_finger_dist_range == (0.0, pytest.approx(0.088))
    grip.joint_pos = [0.012, 0.012]  # closed on the 25 mm cube
    assert grip.inter_finger_dist == pytest.approx(0.024)
    assert not grip.is_open
    grip.joint_pos = [0.044, 0.044]
    assert grip.is_open
    grip.set_gripper_ctrl_open(True)
    np.testing.assert_array_equal(grip.ctrl, [0.044])


def test_unbound_gripper_fails_clearly(toy_model):
    grip = GripperGroup(toy_model, "gripper", ["fa", "fb"], "grip")
    with pytest.raises(UserError, match="'gripper' is not bound"):
        grip.set_gripper_ctrl_open(True)
