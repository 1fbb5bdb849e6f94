"""Arm groups: one position actuator per joint (targets clipped to the actuators' ranges) and
the mocap-driven arm (a 7-value pose, its quaternion normalized)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.arm_groups import (
    ArmMoveGroup,
    MocapArmGroup,
    SimplyActuatedMoveGroup,
)

ASSETS = Path(ASSETS_DIR)
ARM_JOINTS = [f"joint_{i}" for i in range(6)]


def test_simply_actuated_group(wxai):
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    assert isinstance(arm, SimplyActuatedMoveGroup)
    assert arm.ctrl_dim == 6
    low, high = arm.ctrl_limits.T
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
