"""TrossenMujoco/MobileAIPickPlace-v0: the base's two action values drive it at the commanded
speed on the flat floor (issue 39's check, through the gym env).

From rest the wheel speeds ramp at the base's acceleration limit (``MOBILE_AI_BASE_LIMITS``,
0.8 m/s^2 at the faster rim: under what the wheels' 4 N m give), so a 0.5 m/s command
covers v t - v^2 / (2 a) in its first t s (0.1 m in 0.5 s), then runs at the command.
"""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.robot.configs import MOBILE_AI_BASE_LIMITS

ENV_ID = "TrossenMujoco/MobileAIPickPlace-v0"
POLICY_DT = 0.02  # the task's policy_dt (s)
ACCEL = MOBILE_AI_BASE_LIMITS.acceleration
#: stated accuracy of the steady speed, relative to the command (measured 0.0-0.6 %)
SPEED_TOL = 0.01


def holding_action(env, x_vel: float, theta_vel: float) -> np.ndarray:
    """(16,) action: every arm and gripper held where it is (joint_position mode: its control
    on [-1, 1]), then the base's [x.vel, theta.vel] over its limits."""
    mapper = env.unwrapped.actions
    data = env.unwrapped.scene.data
    values = []
    for arm, gripper in mapper.arms:
        for group in (arm, gripper):
            low, high = group.ctrl_limits.T
            values.append((2 * group.get_ctrl(data) - (low + high)) / (high - low))
    base = [x_vel / MOBILE_AI_BASE_LIMITS.x_vel, theta_vel / MOBILE_AI_BASE_LIMITS.theta_vel]
    action = np.concatenate([*values, base]).astype(np.float32)
    assert action.shape == env.action_space.shape
    return action


def planar(env) -> np.ndarray:
    robot = env.unwrapped.actions.robot
    return robot.view.get_move_group("base").get_planar_pose(env.unwrapped.scene.data)


def drive(env, action: np.ndarray, seconds: float) -> None:
    for _ in range(round(seconds / POLICY_DT)):
        env.step(action)


@pytest.mark.parametrize("x_vel", [-0.5, 0.3])
def test_a_forward_command_moves_the_base_at_its_speed(make_env, x_vel):
    env = make_env(ENV_ID)
    env.reset(seed=0)
    action = holding_action(env, x_vel, 0.0)
    start = planar(env)
    drive(env, action, 1.0)  # 0.625 s of ramp at most, then the command
    after_ramp = planar(env)
    ramp = abs(x_vel) / ACCEL
    expected = abs(x_vel) * 1.0 - abs(x_vel) * ramp / 2
    moved = float(np.hypot(*(after_ramp - start)[:2]))
    assert moved == pytest.approx(expected, rel=0.03)
    drive(env, action, 0.5)
    end = planar(env)
    delta = (end - after_ramp)[:2]
    heading = np.array([np.cos(end[2]), np.sin(end[2])])
    speed = float(heading @ delta) / 0.5  # signed: along the heading
    assert speed == pytest.approx(x_vel, rel=SPEED_TOL)
    assert abs(end[2] - start[2]) < 0.01  # straight on


def test_a_turn_command_turns_the_base_at_its_rate(make_env):
    env = make_env(ENV_ID)
    env.reset(seed=1)
    action = holding_action(env, 0.0, 0.5)
    drive(env, action, 0.5)  # the turn's ramp: 0.12 s
    before = planar(env)
    drive(env, action, 1.0)
    after = planar(env)
    rate = float(np.angle(np.exp(1j * (after[2] - before[2])))) / 1.0
    assert rate == pytest.approx(0.5, rel=SPEED_TOL)
    assert np.hypot(*(after - before)[:2]) < 0.01  # on the spot
