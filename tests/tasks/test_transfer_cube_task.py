"""Transfer-cube task: reuses TransferCubeReward and sample_cube_pose (nothing twice)."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.transfer_cube import TransferCubeReward, sample_cube_pose


@pytest.fixture(scope="module")
def sampler():
    s = registry.make_sampler("transfer_cube")
    yield s
    s.close()


def test_cube_spawn_is_sample_cube_pose(sampler):
    task = sampler.sample_task(11)
    expected = sample_cube_pose(np.random.default_rng(11))
    np.testing.assert_allclose(task.get_observation()["cube_pose"], expected)
    np.testing.assert_allclose(task.get_observation()["qpos"], START_ARM_POSE)


def test_reward_is_transfer_cube_reward(sampler):
    task = sampler.sample_task(0)
    reference = TransferCubeReward(sampler.env.model)
    for _ in range(5):
        task.step({})
        assert task.get_reward() == reference(sampler.env.data) == 0
    assert task.judge_success() is False
    assert isinstance(task.reward_fn, TransferCubeReward)


def test_commands_reach_both_arms(sampler):
    task = sampler.sample_task(0)
    view = task.robot.view
    target = view.group("right_arm").get_qpos(task.data) + 0.2
    for _ in range(30):
        task.step({"right_arm": target, "right_gripper": np.array([0.02])})
    np.testing.assert_allclose(view.group("right_arm").get_qpos(task.data), target, atol=0.03)
    assert view.group("right_gripper").get_qpos(task.data)[1] == pytest.approx(0.02, abs=0.003)
