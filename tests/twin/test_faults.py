"""The served arm's joint limits and input checks (no network)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from trossen_arm_mujoco.real.controller_checks import (
    EFFORT,
    EXTERNAL_EFFORT,
    IDLE,
    JOINT_LIMIT_EXCEEDED,
    POSITION,
    ROBOT_INPUT_INFINITE,
    VELOCITY,
    InputChecker,
)
from trossen_arm_mujoco.real.controller_checks import controller_limits as served_limits
from trossen_arm_mujoco.real.validate import ArmLimits
from trossen_arm_mujoco.twin.faults import (
    SETPOINT_LAG_S,
    lag_fault,
    pack_limits,
    unpack_limits,
)

START = [0.0, 0.26, 0.26, 0.0, 0.0, 0.0, 0.02]


def position(values, vel=None):
    vel = vel if vel is not None else [0.0] * 7
    return [POSITION] * 7, [(p, v, 0.0) for p, v in zip(values, vel)]


def test_limits_come_from_the_mjcf_and_urdf() -> None:
    limits, arm = served_limits(), ArmLimits.from_mjcf()
    assert len(limits) == 7
    for j, lim in enumerate(limits):
        assert lim.position_min == pytest.approx(arm.driver_lower[j])
        assert lim.position_max == pytest.approx(arm.driver_upper[j])
        assert lim.velocity_max == pytest.approx(arm.velocity[j])
    assert limits[0].effort_max == 27.0 and limits[5].effort_max == 7.0
    assert limits[6].position_max == pytest.approx(0.044) and limits[6].position_tolerance == 0.001


def test_limits_survive_the_wire_layout() -> None:
    limits = served_limits()
    back = unpack_limits(pack_limits(limits), 7)
    for a, b in zip(limits, back):
        assert b.position_max == pytest.approx(a.position_max, abs=1e-6)
        assert b.velocity_tolerance == pytest.approx(a.velocity_tolerance, rel=1e-6)
    with pytest.raises(ValueError, match="bytes"):
        unpack_limits(b"\0" * 10, 7)
    bad = served_limits()
    bad[0].position_min = math.nan
    with pytest.raises(ValueError, match="invalid joint limit"):
        unpack_limits(pack_limits(bad), 7)


def test_positions_within_the_tolerance_pass_beyond_fault() -> None:
    checker = InputChecker(served_limits())
    hi = served_limits()[0].position_max
    assert checker.check(*position([hi + 0.009, *START[1:]])) is None
    fault = checker.check(*position([hi + 0.02, *START[1:]]))
    assert fault is not None and fault.state == JOINT_LIMIT_EXCEEDED
    assert "joint_0" in fault.reason and "outside the joint limits" in fault.reason
    fault = InputChecker(served_limits()).check(*position([*START[:6], -0.002]))
    assert fault is not None and "gripper" in fault.reason and " m " in fault.reason


def test_feedforward_velocity_beyond_the_limit_faults() -> None:
    checker = InputChecker(served_limits())
    ok = [3.3, 0, 0, 6.9, 0, 0, 0.09]
    assert checker.check(*position(START, ok)) is None
    fault = InputChecker(served_limits()).check(*position(START, [0, 0, 0, 7.8, 0, 0, 0]))
    assert fault is not None and "joint_3: feedforward velocity 7.8" in fault.reason


def test_a_target_far_ahead_of_the_setpoint_is_a_fault() -> None:
    """A goal_time=0 jump: the target runs ahead of the rate-limited setpoint."""
    limits = served_limits()
    allowed = (limits[0].velocity_max + limits[0].velocity_tolerance) * SETPOINT_LAG_S
    assert lag_fault(0, 0.9 * allowed, limits[0]) is None
    fault = lag_fault(0, 1.1 * allowed, limits[0])
    assert fault is not None and fault.state == JOINT_LIMIT_EXCEEDED
    assert fault.reason.startswith("joint_0: the target runs")
    assert lag_fault(6, 0.018, limits[6]) is None and lag_fault(6, 0.021, limits[6]) is not None


def test_non_finite_inputs_and_efforts() -> None:
    checker = InputChecker(served_limits())
    modes, values = position(START)
    values[2] = (0.1, math.inf)
    fault = checker.check(modes, values)
    assert fault is not None and fault.state == ROBOT_INPUT_INFINITE
    modes = [EXTERNAL_EFFORT] * 6 + [EFFORT]
    values = [(0.0, 0.0, 1.0)] * 6 + [(0.0, 0.0, 500.0)]
    fault = checker.check(modes, values)
    assert fault is not None and "gripper: effort command 500 N" in fault.reason
    values[6] = (0.0, 0.0, -10.0)
    assert checker.check(modes, values) is None
    fault = checker.check([VELOCITY] * 7, [(0.0, 4.0, 0.0)] * 7)
    assert fault is not None and "velocity command 4" in fault.reason
    assert checker.check([IDLE] * 7, [(0.0, 0.0, 0.0)] * 7) is None


def test_client_limits_replace_the_defaults() -> None:
    limits = served_limits()
    limits[1].position_max = 0.5
    checker = InputChecker(served_limits())
    checker.set_limits(limits)
    values = np.array(START)
    values[1] = 0.6
    fault = checker.check(*position(values))
    assert fault is not None and "[0, 0.5] rad" in fault.reason
