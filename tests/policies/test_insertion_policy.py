"""Scripted peg insertion: valid, reproducible waypoints within the real speed limits, and one
seeded episode through both recording phases (mocap rollout, joint replay) that succeeds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import ACTION_SPEED_LIMITS, limit_speed
from trossen_arm_mujoco.constants import ASSETS_DIR, GRIPPER_OPEN
from trossen_arm_mujoco.policies.insertion import (
    GRIPPER_SPEED,
    NOISE_CONTACT,
    NOISE_FREE,
    InsertionPolicy,
)
from trossen_arm_mujoco.policies.scripted import check_waypoints
from trossen_arm_mujoco.robot.configs import (
    JOINT_VELOCITY_LIMITS,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
)
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.insertion import MAX_REWARD, InsertionReward, sample_insertion_poses

STATIONARY = Path(ASSETS_DIR) / "stationary_ai"
ROBOT = "stationary_ai"
OBJECTS = {"peg": ("peg_joint", "peg"), "socket": ("socket_joint", "socket-1")}
FPS = 50.0
GROUPS = ("left_arm", "left_gripper", "right_arm", "right_gripper")


class TimeStep:
    def __init__(self, observation: dict):
        self.observation = observation


def start_scene(xml: str, config, peg, socket) -> Scene:
    scene = Scene(STATIONARY / xml, robots={ROBOT: config}, objects=OBJECTS, ctrl_dt=0.02)
    scene.reset()
    scene.objects["peg"].set_pose(scene.data, peg)
    scene.objects["socket"].set_pose(scene.data, socket)
    scene.forward()
    scene.robots[ROBOT].hold(scene.data)
    return scene


def observation(scene: Scene) -> dict:
    view = scene.robots[ROBOT].view
    return {
        "env_state": np.concatenate(
            [
                scene.objects["peg"].get_pose(scene.data),
                scene.objects["socket"].get_pose(scene.data),
            ]
        ),
        "mocap_pose_left": view.get_move_group("left_arm").get_ctrl(scene.data),
        "mocap_pose_right": view.get_move_group("right_arm").get_ctrl(scene.data),
    }


def first_step(seed: int = 0) -> TimeStep:
    """The first observation of the mocap scene with the objects of ``seed``."""
    peg, socket = sample_insertion_poses(np.random.default_rng(seed))
    scene = start_scene("trossen_ai_insertion_scene.xml", stationary_ai_mocap_config(), peg, socket)
    return TimeStep(observation(scene))


@pytest.fixture(scope="module")
def episode():
    """Seed 3 with noise, both phases, as the recorder runs them. Returns (actions (T, 16),
    rewards (T,))."""
    rng = np.random.default_rng(3)
    peg, socket = sample_insertion_poses(rng)
    policy = InsertionPolicy(inject_noise=True, rng=rng)
    T = InsertionPolicy.minimum_episode_len
    # phase 1: scripted mocap rollout; arm joints recorded, fingers = gripper command
    ee = start_scene("trossen_ai_insertion_scene.xml", stationary_ai_mocap_config(), peg, socket)
    robot, view = ee.robots[ROBOT], ee.robots[ROBOT].view
    layout = view.qpos_indices(GROUPS)
    actions = np.empty((T, 16))
    ts = TimeStep(observation(ee))
    for t in range(T):
        a = policy(ts)
        robot.update_control(
            {
                "left_arm": a[0:7],
                "left_gripper": a[7:8],
                "right_arm": a[8:15],
                "right_gripper": a[15:16],
            }
        )
        ee.step(1)
        ts = TimeStep(observation(ee))
        actions[t] = ee.data.qpos[layout]
        actions[t, 6:8], actions[t, 14:16] = a[7], a[15]
    # phase 2: replay as joint targets in the joint scene
    scene = start_scene(
        "trossen_ai_insertion_scene_joint.xml", stationary_ai_joint_config(), peg, socket
    )
    ranges = np.concatenate(
        [scene.robots[ROBOT].view.get_move_group(g).joint_range for g in GROUPS]
    )
    assert np.all(actions >= ranges[:, 0] - 1e-3) and np.all(actions <= ranges[:, 1] + 1e-3)
    np.clip(actions, ranges[:, 0], ranges[:, 1], out=actions)
    reward = InsertionReward(scene.model)
    rewards = np.empty(T, dtype=int)
    for t, a in enumerate(actions):
        scene.robots[ROBOT].update_control(
            {
                "left_arm": a[0:6],
                "left_gripper": a[7:8],
                "right_arm": a[8:14],
                "right_gripper": a[15:16],
            }
        )
        scene.step(1)
        rewards[t] = reward(scene.data)
    assert scene.warnings() == [] and ee.warnings() == []
    return actions, rewards


def test_both_phases_reach_reward_4(episode):
    _, rewards = episode
    assert rewards[-1] == MAX_REWARD
    # the stages come in order: grasped (1), lifted (2), inserted (4) before the end
    first = {r: int(np.argmax(rewards >= r)) for r in (1, 2, 4)}
    assert 0 < first[1] < first[2] < first[4] < len(rewards) - 10
    assert np.all(rewards[first[4] :] == MAX_REWARD)  # held to the end


def test_recorded_actions_within_the_speed_limits(episode):
    actions, _ = episode
    speed = np.abs(np.diff(actions, axis=0)) * FPS / ACTION_SPEED_LIMITS
    joints = np.r_[0:6, 8:14]
    assert speed[:, joints].max() < 0.6  # well under 3.375 / 7 rad/s
    assert speed[:, [6, 7, 14, 15]].max() <= 0.8 + 1e-6  # gripper: 0.07 m/s planned
    assert limit_speed(actions.copy(), ACTION_SPEED_LIMITS, FPS) == 0


@pytest.fixture(scope="module")
def ts_first():
    return first_step(0)


def plan(ts, noise: bool, seed) -> InsertionPolicy:
    policy = InsertionPolicy(inject_noise=noise, rng=seed)
    policy.generate_trajectory(ts)
    return policy


def test_waypoints_are_valid(ts_first):
    policy = plan(ts_first, True, 1)
    gripper_limit = JOINT_VELOCITY_LIMITS["left_carriage_joint"]
    for name, traj in (("left", policy.left_trajectory), ("right", policy.right_trajectory)):
        check_waypoints(traj, name)
        assert traj[-1]["t"] == InsertionPolicy.minimum_episode_len
        for w in traj:
            assert np.linalg.norm(w["quat"]) == pytest.approx(1.0)
            assert 0.0 <= w["gripper"] <= GRIPPER_OPEN
            assert w["xyz"][2] > 0.025  # fingertips above the table top (z = 0.02)
        for a, b in zip(traj, traj[1:]):
            dt = (b["t"] - a["t"]) / FPS
            assert abs(b["gripper"] - a["gripper"]) / dt <= GRIPPER_SPEED + 1e-9
            assert GRIPPER_SPEED <= 0.8 * gripper_limit + 1e-12
    assert policy.left_trajectory[0]["gripper"] == GRIPPER_OPEN


def test_same_seed_same_trajectory(ts_first):
    a, b, c = plan(ts_first, True, 5), plan(ts_first, True, 5), plan(ts_first, True, 6)
    for side in ("left_trajectory", "right_trajectory"):
        for wa, wb in zip(getattr(a, side), getattr(b, side)):
            np.testing.assert_array_equal(wa["xyz"], wb["xyz"])
            np.testing.assert_array_equal(wa["quat"], wb["quat"])
    differs = [
        not np.array_equal(wa["xyz"], wc["xyz"])
        for wa, wc in zip(a.right_trajectory, c.right_trajectory)
    ]
    assert any(differs)
    steps = [a(ts_first) for _ in range(3)]
    assert len(steps[0]) == 16 and np.all(np.isfinite(steps))


def test_noise_is_bounded_and_optional(ts_first):
    clean = plan(ts_first, False, 1)
    np.testing.assert_array_equal(
        clean.right_trajectory[-1]["xyz"], plan(ts_first, False, 2).right_trajectory[-1]["xyz"]
    )
    noisy = plan(ts_first, True, 1)
    for side in ("left_trajectory", "right_trajectory"):
        for wc, wn in zip(getattr(clean, side), getattr(noisy, side)):
            # a waypoint moves by its own jitter plus one grasp's jitter at most
            bound = NOISE_FREE + NOISE_CONTACT + 1e-12
            assert np.abs(wc["xyz"] - wn["xyz"]).max() <= bound
