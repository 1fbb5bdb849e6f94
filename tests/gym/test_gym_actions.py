"""Action modes, action validation, and the robot layer's safety floor behind every mode."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.kinematics import Kinematics

REACH = "TrossenMujoco/WXAIReach-v0"


def _ee_z(env):
    return env.unwrapped.task.ee_pos()[2]


def _floor_z(env) -> float:
    """Height (m) of the robot's safety floor: table_height + safety_margin."""
    return env.unwrapped.actions.robot.safety_floor.floor_z


@pytest.mark.parametrize(
    "mode, dim", [("joint_position", 7), ("joint_rel_position", 7), ("ee_delta", 4)]
)
def test_action_dims(make_env, mode, dim):
    env = make_env(REACH, action_mode=mode)
    assert env.action_space.shape == (dim,)
    assert np.all(env.action_space.low == -1) and np.all(env.action_space.high == 1)


def test_transfer_cube_actions_cover_both_arms(make_env):
    env = make_env("TrossenMujoco/StationaryAITransferCube-v0", action_mode="ee_delta")
    assert env.action_space.shape == (8,)
    assert make_env("TrossenMujoco/StationaryAITransferCube-v0").action_space.shape == (14,)


def test_ee_delta_moves_tool_frame(make_env):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    x0 = env.unwrapped.task.ee_pos()
    for _ in range(15):  # 0.3 s: the joints' speed limits allow about 0.13 m here
        env.step(np.array([1.0, 0.0, 0.0, 0.0]))
    moved = env.unwrapped.task.ee_pos() - x0
    assert moved[0] > 0.1 and abs(moved[1]) < 0.02 and abs(moved[2]) < 0.02


def test_ee_delta_hold_orientation(make_env):
    env = make_env("TrossenMujoco/WXAIPush-v0", action_mode="ee_delta")
    env.reset(seed=0)
    arm = env.unwrapped.task.arm
    quat0 = arm.get_frame_pose(env.unwrapped.scene.data)[3:]
    # 10 steps: further on this command drives joint_3 and joint_2 onto their limits, where
    # no IK can hold the orientation (even without speed limits it drifted 9 deg at step 15)
    for _ in range(10):
        env.step(np.array([0.5, 0.7, 0.3, 0.0]))
        quat = arm.get_frame_pose(env.unwrapped.scene.data)[3:]
        assert abs(np.dot(quat, quat0)) > np.cos(np.radians(5) / 2)


def test_safety_floor_ee_delta(make_env):
    env = make_env("TrossenMujoco/WXAIPush-v0", action_mode="ee_delta")
    env.reset(seed=0)
    floor = _floor_z(env)
    clipped = []
    for _ in range(40):
        _, _, _, _, info = env.step(np.array([0.0, 0.0, -1.0, 0.0]))
        clipped.append(info["safety_clipped"])
        assert _ee_z(env) > floor - 0.005
    assert not clipped[0] and clipped[-1]


def test_safety_floor_joint_position(make_env):
    env = make_env(REACH, action_mode="joint_position", safety_margin=0.05)
    env.reset(seed=0)
    u = env.unwrapped
    arm = u.task.arm
    # joint_1 (shoulder) far forward, elbow extended: the tool would go under the table
    low, high = arm.ctrl_limits.T
    target = np.array([0.0, 2.6, 0.3, 0.0, 0.0, 0.0])
    action = np.append(2 * (target - low) / (high - low) - 1, 1.0)
    kin = Kinematics(u.scene.model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range)
    floor = _floor_z(env)
    assert floor == pytest.approx(0.05)
    assert kin.site_pose(u.scene.data.qpos, target)[2] < floor
    clipped = []
    for _ in range(60):  # toward the target at the speed limits, then held at the floor
        _, _, _, _, info = env.step(action)
        clipped.append(info["safety_clipped"])
        assert _ee_z(env) > floor - 0.01
        # the joint targets the robot holds keep the tool frame above the floor
        assert kin.site_pose(u.scene.data.qpos, arm.get_ctrl(u.scene.data))[2] >= floor
    assert not clipped[0] and all(clipped[-20:])


class _WithoutBatches:
    """The robot, offering no ``JointTargetBatch``: the action mapper goes arm by arm."""

    def __init__(self, robot):
        self._robot = robot

    def __getattr__(self, name):
        return getattr(self._robot, name)

    def joint_target_batch(self, names):
        return None


@pytest.mark.parametrize("env_id", [REACH, "TrossenMujoco/StationaryAITransferCube-v0"])
def test_joint_position_actions_as_one_vector_equal_arm_by_arm(make_env, env_id):
    """The joint_position actions go to the robot as one vector (``JointTargets`` of the
    robot's batch, the step's end from its ``preview``); arm by arm, through each
    controller's ``limit``, gives the same controls, floor and reports, bit for bit."""
    # a high floor, so that it holds the arms up often
    batched, by_arm = (make_env(env_id, safety_margin=0.15) for _ in range(2))
    by_arm.unwrapped.actions.robot = _WithoutBatches(by_arm.unwrapped.actions.robot)
    for env in (batched, by_arm):
        env.reset(seed=3)
    rng = np.random.default_rng(3)
    clipped = 0
    for _ in range(120):
        action = rng.uniform(-1, 1, batched.action_space.shape)
        commands = batched.unwrapped.actions(batched.unwrapped.scene.data, action)
        assert type(commands).__name__ == "JointTargets"
        _, r1, _, _, info1 = batched.step(action)
        _, r2, _, _, info2 = by_arm.step(action)
        assert np.array_equal(batched.unwrapped.scene.data.ctrl, by_arm.unwrapped.scene.data.ctrl)
        assert np.array_equal(batched.unwrapped.scene.data.qpos, by_arm.unwrapped.scene.data.qpos)
        assert (r1, info1["safety_links"]) == (r2, info2["safety_links"])
        clipped += info1["safety_clipped"]
    assert clipped > 0


def test_safety_floor_joint_rel_position(make_env):
    env = make_env(REACH, action_mode="joint_rel_position")
    env.reset(seed=0)
    action = np.array([0.0, 1.0, -1.0, 0.0, 0.0, 0.0, 1.0])  # fold forward and down
    seen = False
    for _ in range(40):
        _, _, _, _, info = env.step(action)
        seen |= info["safety_clipped"]
        assert _ee_z(env) > _floor_z(env) - 0.01
    assert seen


def test_gripper_action_maps_to_finger_travel(make_env):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    u = env.unwrapped
    commands = u.actions(u.scene.data, np.array([0, 0, 0, -1.0]))
    assert commands["gripper"][0] == pytest.approx(0.0)
    commands = u.actions(u.scene.data, np.array([0, 0, 0, 1.0]))
    assert commands["gripper"][0] == pytest.approx(0.044)


def test_out_of_range_actions_are_clipped(make_env):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    u = env.unwrapped
    big = u.actions(u.scene.data, np.array([5.0, 0, 0, 0]))
    one = u.actions(u.scene.data, np.array([1.0, 0, 0, 0]))
    np.testing.assert_array_equal(big["arm"], one["arm"])


@pytest.mark.parametrize("action", [np.zeros(3), np.array([np.nan, 0, 0, 0])])
def test_bad_actions_are_user_errors(make_env, action):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    with pytest.raises(UserError):
        env.step(action)


def test_unknown_action_mode_lists_modes(make_env):
    with pytest.raises(UserError, match="ee_delta.*joint_position"):
        make_env(REACH, action_mode="torque")
