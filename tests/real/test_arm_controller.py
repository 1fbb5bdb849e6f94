"""The controller model in-process evaluation and the served kit share: the driver's
trajectory toward a goal and the arm controller's checks (real.arm_controller,
real.controller_checks)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from trossen_arm_mujoco.real import controller_checks
from trossen_arm_mujoco.real.arm_controller import (
    VALUE_LABELS,
    KitController,
    controller_target,
)
from trossen_arm_mujoco.real.controller_checks import controller_limits
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX

HOME = np.zeros(14)
HOME[[6, 13]] = 0.02  # grippers half open


def test_the_served_kit_checks_with_the_same_code():
    from trossen_arm_mujoco.twin import arm_adapter, faults

    assert arm_adapter.InputChecker is controller_checks.InputChecker
    assert arm_adapter.controller_limits is controller_checks.controller_limits
    assert arm_adapter.controller_target is controller_target
    assert faults.Fault is controller_checks.Fault


def test_a_goal_becomes_a_linear_ramp_over_the_goal_time():
    ctl = KitController()
    ctl.reset(HOME)
    goal = HOME.copy()
    goal[0] = 0.06  # 0.06 rad in 0.06 s: 1 rad/s
    ctl.command(goal, 0.06)
    target, fault = ctl.tick(0.02)
    assert fault is None
    assert target[0] == pytest.approx(0.02)
    assert ctl.peak_fraction[0] == pytest.approx(1.0 / controller_limits()[0].velocity_max)
    for _ in range(5):
        target, _ = ctl.tick(0.02)
    assert target[0] == pytest.approx(0.06)  # arrived, then holds


def test_a_jump_faults_naming_the_joint_the_speed_and_the_limit():
    ctl = KitController()
    ctl.reset(HOME)
    goal = HOME.copy()
    goal[8] += 1.0  # right joint_1 by 1 rad in 0.06 s: 16.7 rad/s
    ctl.command(goal, 0.06)
    _, fault = ctl.tick(0.002)
    assert fault is not None and ctl.fault == fault and ctl.fault_tick == 1
    assert fault.joint == "right_joint_1" and fault.kind == "speed"
    assert fault.asked == pytest.approx(1.0 / 0.06) and fault.limit == 3.375
    assert "right arm joint_1" in fault.reason and "3.375 rad/s" in fault.reason
    assert fault.as_dict()["joint"] == "right_joint_1"


def test_within_the_tolerance_passes_beyond_it_faults():
    vmax = controller_limits()[6].velocity_max  # the gripper, m/s
    for factor, faults in ((1.09, False), (1.11, True)):
        ctl = KitController()
        ctl.reset(HOME)
        goal = HOME.copy()
        goal[6] -= factor * vmax * 0.06
        ctl.command(goal, 0.06)
        _, fault = ctl.tick(0.002)
        assert (fault is not None) is faults, factor
    assert fault.joint == "left_gripper"


def test_positions_outside_the_range_and_non_finite_goals_fault():
    lims = controller_limits()
    ctl = KitController()
    ctl.reset(HOME)
    goal = HOME.copy()
    goal[2] = lims[2].position_max + 0.05
    ctl.command(goal, 10.0)  # slow: no speed fault, the quintic ends past the range
    fault = None
    for _ in range(6000):
        _, fault = ctl.tick(0.002)
        if fault:
            break
    assert fault is not None and fault.kind == "position" and fault.joint == "left_joint_2"
    assert fault.limit == lims[2].position_max
    ctl.reset(HOME)
    goal = HOME.copy()
    goal[5] = math.nan
    ctl.command(goal, 0.06)
    _, fault = ctl.tick(0.002)
    assert fault is not None and fault.kind == "non-finite" and fault.joint == "left_joint_5"


def test_checks_off_refuses_nothing_and_clips_like_the_controller():
    ctl = KitController(checks=False)
    ctl.reset(HOME)
    goal = HOME.copy()
    goal[0] += 5.0
    goal[13] = 0.044  # the gripper fully open: the controller takes at most GRIPPER_MAX
    ctl.command(goal, 0.06)
    for _ in range(40):
        target, fault = ctl.tick(0.002)
        assert fault is None
    assert ctl.fault is None
    assert target[0] == controller_limits()[0].position_max
    assert target[13] == GRIPPER_MAX
    assert ctl.peak_fractions()["left_joint_0"] > 20  # still measured
    assert list(ctl.peak_fractions()) == list(VALUE_LABELS)
