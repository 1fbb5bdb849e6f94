"""The Mobile AI's differential-drive base: velocity commands move it at the commanded speed
on a flat floor, out-of-limit commands are clipped and counted like the real base's, and the
arms ride on it."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot import Robot
from trossen_arm_mujoco.robot.configs import (
    MOBILE_AI_BASE_LIMITS,
    MOBILE_AI_WHEEL_RADIUS,
    MoveGroupSpec,
    mobile_ai_config,
)
from trossen_arm_mujoco.robot.diff_drive import BaseVelocityLimits, DiffDriveBaseGroup

MOBILE = Path(ASSETS_DIR) / "mobile_ai" / "mobile_ai.xml"
CTRL_DT = 0.02
#: Stated accuracy of the base's speed on a flat floor, relative to the command (measured:
#: 0.2-0.4 % slow, mostly the tyres' 0.2-0.5 mm contact penetration shortening the rolling
#: radius).
SPEED_TOL = 0.01
#: The wheel speeds' ramp, m/s^2 at the rim (MOBILE_AI_BASE_LIMITS).
ACCEL = MOBILE_AI_BASE_LIMITS.acceleration


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(MOBILE))


@pytest.fixture
def robot(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    robot = Robot(model, mobile_ai_config(), ctrl_dt=CTRL_DT, data=data)
    robot.reset()
    return robot


def run(robot: Robot, seconds: float) -> None:
    data = robot.view.data
    substeps = round(CTRL_DT / robot.model.opt.timestep)
    for _ in range(round(seconds / CTRL_DT)):
        robot.apply_control()
        mujoco.mj_step(robot.model, data, nstep=substeps)


def ramped_wheels(robot: Robot) -> np.ndarray:
    """The wheel speeds (rad/s) the base's command ramps to: control ticks without physics
    until they stop changing."""
    wheels = robot.compute_control()["base"]
    for _ in range(200):
        wheels, last = robot.compute_control()["base"], wheels
        if np.array_equal(wheels, last):
            return wheels
    raise AssertionError(f"the wheel speeds did not settle: {wheels}")


def measured_velocity(robot: Robot, command, settle=1.5, window=1.0) -> np.ndarray:
    """[x.vel, theta.vel] over ``window`` s after ``settle`` s: the distance along the
    heading and the turn, per second (and the reported velocity agrees)."""
    base = robot.view.get_move_group("base")
    robot.update_control({"base": command})
    run(robot, settle)
    x0, y0, yaw0 = base.get_planar_pose(robot.view.data)
    run(robot, window)
    x1, y1, yaw1 = base.get_planar_pose(robot.view.data)
    turn = np.angle(np.exp(1j * (yaw1 - yaw0)))
    chord = np.hypot(x1 - x0, y1 - y0)
    # the arc length of a circle through the chord (straight line when not turning)
    arc = chord if abs(turn) < 1e-6 else chord * (turn / 2) / np.sin(turn / 2)
    heading = np.array([np.cos((yaw0 + yaw1) / 2), np.sin((yaw0 + yaw1) / 2)])
    sign = np.sign(heading @ [x1 - x0, y1 - y0]) or 1.0
    measured = np.array([sign * arc / window, turn / window])
    reported = base.get_base_velocity(robot.view.data)
    np.testing.assert_allclose(reported, measured, atol=0.01)
    return measured


@pytest.mark.parametrize(
    "command", [(0.5, 0.0), (1.0, 0.0), (-0.3, 0.0), (0.0, 0.8), (0.3, -0.5)], ids=str
)
def test_base_moves_at_the_commanded_speed(robot, command):
    measured = measured_velocity(robot, command)
    for got, want in zip(measured, command):
        assert abs(got - want) <= SPEED_TOL * max(abs(want), 0.1), (measured, command)
    assert robot.controllers["base"].clipped_commands == 0


@pytest.mark.parametrize("command", [(0.5, 0.0), (0.6, 0.8), (0.3, -0.5), (0.0, 1.0)], ids=str)
def test_from_rest_the_base_ramps_up_on_the_commanded_path(robot, command):
    """From rest the wheel speeds ramp at ACCEL (m/s^2 at the faster rim), both by one
    factor: after t s the base moves at min(1, ACCEL t / fastest rim speed) times the
    command, x.vel and theta.vel alike (the path's curvature from the start; with the wheels
    at their torque limit instead, the base drove straight for the first 0.5 s)."""
    base = robot.view.get_move_group("base")
    rim = float(np.abs(base.wheel_speeds(*command)).max()) * base.wheel_radius
    robot.update_control({"base": command})
    elapsed = 0.0
    for t in (0.2, 0.5, 1.5):
        run(robot, t - elapsed)
        elapsed = t
        want = min(1.0, ACCEL * t / rim) * np.asarray(command)
        got = base.get_base_velocity(robot.view.data)
        # the servo lags the ramp by a few ms; the casters' swivel slows a turn's first 0.2 s
        np.testing.assert_allclose(got, want, atol=0.04, err_msg=f"at {t} s")
    assert robot.controllers["base"].clipped_commands == 0


def test_from_rest_the_distance_is_the_ramp_then_the_commanded_speed(robot):
    """0.5 m/s from rest for 1 s: v t - v^2 / (2 ACCEL) = 0.344 m (0.625 s of ramp, then
    the commanded speed); 0.25 m would need an instant start."""
    base = robot.view.get_move_group("base")
    x0 = base.get_planar_pose(robot.view.data)[:2]
    robot.update_control({"base": (0.5, 0.0)})
    run(robot, 1.0)
    moved = float(np.hypot(*(base.get_planar_pose(robot.view.data)[:2] - x0)))
    assert moved == pytest.approx(0.5 * 1.0 - 0.5**2 / (2 * ACCEL), rel=0.02)


def test_stop_holds_the_base_still(robot):
    base = robot.view.get_move_group("base")
    measured_velocity(robot, (0.6, 0.3))
    robot.update_control({"base": (0.0, 0.0)})
    run(robot, 3.0)  # the base brakes in about 0.8 s, then rocks on its casters a little
    assert np.abs(base.get_base_velocity(robot.view.data)).max() < 1e-3
    robot.hold()  # the no-op control of the base is zero wheel speed
    np.testing.assert_array_equal(base.ctrl, [0.0, 0.0])


def test_wheel_speeds_map_both_ways(robot):
    base = robot.view.get_move_group("base")
    assert base.wheel_radius == MOBILE_AI_WHEEL_RADIUS
    assert base.track == pytest.approx(0.384)  # URDF wheel joints at y = +-0.192
    r, b = base.wheel_radius, base.track
    np.testing.assert_allclose(base.wheel_speeds(0.5, 0.0), [0.5 / r, 0.5 / r])
    np.testing.assert_allclose(base.wheel_speeds(0.0, 1.0), [-b / 2 / r, b / 2 / r])
    for cmd in ([0.3, -0.7], [-1.0, 0.2]):
        np.testing.assert_allclose(base.body_velocity(base.wheel_speeds(*cmd)), cmd)


@pytest.mark.parametrize(
    "command, executed",
    [
        ((2.5, 0.0), (1.0, 0.0)),  # beyond x.vel 1.0 m/s: clipped to it
        ((0.0, -3.0), (0.0, -1.0)),  # beyond theta.vel 1.0 rad/s
        ((-1.7, 0.2), (-1.0, 0.2)),
    ],
)
def test_out_of_limit_commands_are_clipped_and_counted(robot, command, executed):
    controller = robot.controllers["base"]
    robot.update_control({"base": command})
    assert controller.last_clipped and controller.clipped_commands == 1
    wheels = ramped_wheels(robot)
    base = robot.view.get_move_group("base")
    np.testing.assert_allclose(base.body_velocity(wheels), executed, atol=1e-12)
    robot.update_control({"base": (0.2, 0.1)})  # within the limits: not counted
    assert not controller.last_clipped and controller.clipped_commands == 1


def test_a_command_too_fast_for_the_wheels_keeps_its_curvature(robot):
    base = robot.view.get_move_group("base")
    controller = robot.controllers["base"]
    # 1 m/s and 1 rad/s are each within the limits, but the outer wheel would need
    # (1 + 0.192) / 0.0851 = 14.0 rad/s > the wheels' 4 pi rad/s (URDF velocity limit)
    robot.update_control({"base": (1.0, 1.0)})
    assert controller.clipped_commands == 1
    first = robot.compute_control()["base"]  # the ramp's first tick: the same curvature
    v, w = base.body_velocity(first)
    assert v / w == pytest.approx(1.0)
    assert np.abs(first).max() * base.wheel_radius == pytest.approx(ACCEL * CTRL_DT)
    wheels = ramped_wheels(robot)
    assert np.abs(wheels).max() == pytest.approx(4 * np.pi)
    v, w = base.body_velocity(wheels)
    assert v / w == pytest.approx(1.0) and v < 1.0


def test_limits_are_the_real_base_and_the_arms_keep_theirs():
    config = mobile_ai_config()
    # trossen_slate MAX_VEL_X/Z; the ramp stays under what the wheels' 4 N m give (0.97 m/s^2)
    assert MOBILE_AI_BASE_LIMITS == BaseVelocityLimits(1.0, 1.0, acceleration=0.8)
    assert config.groups["base"].base_limits == MOBILE_AI_BASE_LIMITS
    for side in ("left", "right"):
        assert config.groups[f"{side}_arm"].velocity_limits == (3.375,) * 3 + (7.0,) * 3
        assert config.groups[f"{side}_gripper"].velocity_limits == (0.0875,)
    assert config.command_mode["base"] == "base_velocity"


def test_teleport_moves_the_arms_with_the_base(robot):
    data = robot.view.data
    left = robot.view.get_move_group("left_base")
    mount = np.linalg.inv(robot.get_world_pose()) @ left.pose  # the arm's mount on the base
    robot.set_world_pose([1.0, -2.0, 0.211, np.cos(0.4), 0.0, 0.0, np.sin(0.4)])
    base = robot.view.get_move_group("base")
    np.testing.assert_allclose(base.get_planar_pose(data), [1.0, -2.0, 0.8], atol=1e-12)
    np.testing.assert_allclose(left.pose, robot.get_world_pose() @ mount, atol=1e-9)
    with pytest.raises(UserError, match="carried by body 'base_link'"):
        left.pose = np.eye(4)
    base.set_planar_pose(data, 0.5, 0.5, -1.0)
    np.testing.assert_allclose(base.get_planar_pose(data), [0.5, 0.5, -1.0], atol=1e-12)
    assert base.joint_pos[2] == pytest.approx(0.211)


def test_safety_floor_holds_the_arms_on_a_mobile_base(robot):
    # a table top at 0.9 m: the arm reaching down to 0.83 m (tool frame) is held above it
    robot.set_safety_floor(0.9)
    robot.update_control({"left_arm": [0.0, 2.5, 0.5, 0.0, 0.0, 0.0]})
    run(robot, 2.0)
    assert robot.floor_report.clipped
    data, floor = robot.view.data, robot.safety_floor
    ctrl = robot.view.get_move_group("left_arm").ctrl
    # the held control, checked each tick at that tick's base pose: the base rocks on its
    # wheels' contacts under the arm's reaction by a fraction of a millimetre since
    assert floor.lowest(data.qpos, "left_arm", ctrl)[0] >= 0.9 - 0.001
    assert floor.lowest(data.qpos, "left_arm")[0] > 0.9 - 0.005  # the arm, following it


@pytest.mark.parametrize(
    "command, match",
    [
        ((0.1,), "expected 2 values"),
        ((0.1, float("nan")), "NaN"),
    ],
)
def test_bad_base_commands_fail_in_one_line(robot, command, match):
    with pytest.raises(UserError, match=match):
        robot.update_control({"base": command})


def test_bad_base_groups_fail_in_one_line(model):
    wheels = ("left_wheel", "right_wheel")
    with pytest.raises(UserError, match="not a free joint"):
        DiffDriveBaseGroup(model, "b", "left_wheel", wheels, wheels, 0.08)
    with pytest.raises(UserError, match="does not drive wheel"):
        DiffDriveBaseGroup(model, "b", "base_joint", wheels, ("right_wheel",) * 2, 0.08)
    with pytest.raises(UserError, match="wheel radius"):
        DiffDriveBaseGroup(model, "b", "base_joint", wheels, wheels, 0)
    with pytest.raises(UserError, match="base velocity limit x_vel"):
        BaseVelocityLimits(-1.0, 1.0)
    with pytest.raises(UserError, match="fixed to the world"):
        MoveGroupSpec("carried_base", base_body="world").build(model, "b")
