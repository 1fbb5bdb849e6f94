"""Reach task: scripted IK reaches the target; reward and success follow the distance."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.tasks import registry


@pytest.fixture(scope="module")
def sampler():
    s = registry.make_sampler("reach")
    yield s
    s.close()


def test_ik_reaches_target(sampler, ik_driver):
    task = sampler.sample_task(5)
    start_reward = task.get_reward()
    assert not task.judge_success()
    # 0.01 m a step (0.5 m/s) keeps the joints near their speed limits; 0.02 m asked for
    # up to 20x the limits (the first step also turns the tool to point down)
    ik_driver(task).move_to(task.desired_goal(), gripper=0.044, step=0.01)
    assert task.judge_success(), task.get_info()
    assert task.get_reward() > start_reward
    np.testing.assert_allclose(task.achieved_goal(), task.ee_pos())


def test_goal_reward_is_vectorized(sampler):
    task = sampler.make_task(goal=[0.3, 0.0, 0.2])
    achieved = np.array([[0.3, 0.0, 0.2], [0.3, 0.0, 0.3], [0.31, 0.0, 0.2]])
    desired = np.tile(task.desired_goal(), (3, 1))
    np.testing.assert_array_equal(task.goal_reward(achieved, desired), [0.0, -1.0, 0.0])
    np.testing.assert_array_equal(task.goal_success(achieved, desired), [True, False, True])
    batch = np.zeros((2, 5, 3))
    assert task.goal_reward(batch, batch).shape == (2, 5)
    assert task.goal_reward(achieved[1], desired[1]) == -1.0


def test_dense_goal_reward():
    s = registry.make_sampler("reach", goal_reward_type="dense")
    try:
        task = s.make_task(goal=[0.3, 0.0, 0.2])
        assert task.goal_reward(np.array([0.3, 0.0, 0.3]), task.goal) == pytest.approx(-0.1)
    finally:
        s.close()


def test_unknown_goal_reward_type():
    from trossen_arm_mujoco.errors import UserError

    with pytest.raises(UserError, match="sparse"):
        registry.make_sampler("reach", goal_reward_type="shaped")
