"""Trajectory validation: every violation is one line naming step, arm, joint and limit."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.real.validate import (
    VELOCITY_LIMITS,
    ArmLimits,
    TrajectoryError,
    format_trajectory_report,
    safe_move_time,
    validate_actions,
)


@pytest.fixture(scope="module")
def limits() -> ArmLimits:
    return ArmLimits.from_mjcf()


def one_line_error(actions: np.ndarray, fps: float, limits: ArmLimits) -> str:
    with pytest.raises(TrajectoryError) as info:
        validate_actions(actions, fps, limits)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def test_limits_come_from_the_mjcf(limits: ArmLimits) -> None:
    assert limits.lower[1] == 0.0 and limits.upper[1] == pytest.approx(3.14159)
    assert limits.upper[2] == pytest.approx(2.35619)
    assert limits.lower[6] == 0.0 and limits.upper[6] == pytest.approx(0.044)
    assert limits.upper[7] == pytest.approx(0.044)
    assert tuple(limits.velocity) == VELOCITY_LIMITS


def test_smooth_trajectory_is_valid_and_split_per_arm(limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    traj = validate_actions(actions, 10.0, limits)
    assert traj.commands.shape == (20, 2, 7)
    np.testing.assert_array_equal(traj.commands[:, 0], actions[:, 0:7])
    np.testing.assert_array_equal(traj.commands[:, 1], actions[:, 8:15])
    assert traj.clipped == 0 and traj.max_fps > 10
    assert "highest valid --fps" in format_trajectory_report(traj, limits)


@pytest.mark.parametrize("shape", [(20, 15), (20,), (0, 16), (2, 16, 1)])
def test_wrong_shape(shape: tuple[int, ...], limits: ArmLimits) -> None:
    msg = one_line_error(np.zeros(shape), 10.0, limits)
    assert "expected (T, 16)" in msg and str(shape) in msg


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_value_names_step_arm_joint(bad: float, limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    actions[7, 8 + 3] = bad
    msg = one_line_error(actions, 10.0, limits)
    assert msg.startswith("step 7, right arm, joint_3:") and "not finite" in msg


def test_out_of_limit_joint_names_value_and_limits(limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    actions[12, 2] = 2.5  # left joint_2 upper limit 2.35619
    msg = one_line_error(actions, 10.0, limits)
    assert msg.startswith("step 12, left arm, joint_2: 2.5 rad is outside the joint limits")
    assert "2.3562" in msg


def test_out_of_limit_finger(limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    actions[3, 15] = 0.05
    msg = one_line_error(actions, 10.0, limits)
    assert msg.startswith("step 3, right arm, left_carriage_joint: 0.05 m")


def test_values_just_outside_a_limit_are_clipped(limits: ArmLimits) -> None:
    actions = np.tile(np.asarray(START_ARM_POSE), (3, 1))
    actions[1, 9] = -0.004  # right joint_1 pressed 4 mrad into its lower limit
    actions[2, 6] = 0.0445  # finger 0.5 mm past open
    traj = validate_actions(actions, 10.0, limits)
    assert traj.clipped == 2 and traj.max_clip == pytest.approx(0.004)
    assert traj.commands[1, 1, 1] == 0.0 and traj.commands[2, 0, 6] == pytest.approx(0.044)


def test_too_fast_names_steps_and_the_fps_that_would_work(limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    actions[10:, 4] += 0.5  # left joint_4 jumps 0.5 rad between steps 9 and 10
    msg = one_line_error(actions, 20.0, limits)
    assert msg.startswith("step 9 -> 10, left arm, joint_4: speed")
    assert "exceeds the limit 7 rad/s" in msg and "--fps 20" in msg
    needed = float(msg.rsplit("--fps ", 1)[1].split()[0])
    validate_actions(actions, needed, limits)  # the suggested rate passes


def test_gripper_speed_is_checked_on_the_sent_finger(limits: ArmLimits, smooth) -> None:
    actions = smooth(20)
    actions[5:, 14] = 0.0  # right gripper snaps shut from ~0.04 m
    msg = one_line_error(actions, 10.0, limits)
    assert msg.startswith("step 4 -> 5, right arm, gripper: speed") and "m/s" in msg


def test_vendor_episode_is_valid_at_10_fps_but_too_fast_at_50(
    limits: ArmLimits, vendor_path
) -> None:
    actions = load_episode(vendor_path).action
    traj = validate_actions(actions, 10.0, limits)
    assert traj.clipped > 0 and traj.max_clip < 0.005  # sim joints pressed into limits
    assert 10.0 <= traj.max_fps < 11.0
    msg = one_line_error(actions, 50.0, limits)
    assert msg.startswith("step 0 -> 1, left arm, joint_1: speed")


def test_safe_move_time_respects_minimum_and_speed(limits: ArmLimits) -> None:
    zero = np.zeros(7)
    assert safe_move_time(zero, zero, 2.0, limits) == 2.0
    far = np.array([6.0, 0, 0, 0, 0, 0, 0])
    t = safe_move_time(zero, far, 2.0, limits)
    assert 1.875 * 6.0 / t < 3.375
