"""Push task: a scripted poke through the cube (robot-layer IK) moves it; scoring."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.tasks import registry


@pytest.fixture(scope="module")
def sampler():
    s = registry.make_sampler("push")
    yield s
    s.close()


def test_scripted_poke_moves_cube(sampler, ik_driver):
    task = sampler.sample_task(3)
    cube0 = task.cube_pos()
    direction = np.array([1.0, 0.0, 0.0])
    drive = ik_driver(task)
    drive.move_to(cube0 - 0.08 * direction + [0, 0, 0.06], gripper=0.0)
    drive.move_to(cube0 - 0.08 * direction + [0, 0, 0.005], gripper=0.0)
    assert np.linalg.norm(task.cube_pos() - cube0) < 0.005  # not touched yet
    drive.move_to(cube0 + 0.05 * direction + [0, 0, 0.005], gripper=0.0)
    moved = task.cube_pos() - cube0
    assert moved[0] > 0.03, moved
    assert abs(task.cube_pos()[2] - cube0[2]) < 0.01  # still on the table
    assert not sampler.scene.warnings()


def test_success_when_cube_on_goal(sampler):
    task = sampler.sample_task(0)
    assert not task.judge_success()
    far = task.get_reward()
    task.goal = task.cube_pos() + [0.01, 0.0, 0.0]
    assert task.judge_success()
    assert task.get_reward() > far
    assert task.get_info()["goal_distance"] == pytest.approx(0.01)


def test_observation_entries(sampler):
    task = sampler.sample_task(1)
    obs = task.get_observation()
    np.testing.assert_allclose(obs["cube_rel"], obs["cube_pos"] - obs["ee_pos"])
    assert obs["cube_quat"].shape == (4,) and obs["cube_vel"].shape == (6,)
    np.testing.assert_allclose(task.achieved_goal(), obs["cube_pos"])
