"""Goal envs: Dict observations; compute_* accept batches and agree with step."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.goal_env import TrossenMujocoGoalEnv

GOAL_IDS = [
    "TrossenMujoco/WXAIReachGoal-v0",
    "TrossenMujoco/WXAIPushGoal-v0",
    "TrossenMujoco/WXAIPickPlaceGoal-v0",
]


def _rollout(env, n=25, seed=0):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    achieved, desired, rewards, infos, terminated = [], [], [], [], []
    for _ in range(n):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(r)
        infos.append(info)
        terminated.append(term)
    return np.array(achieved), np.array(desired), np.array(rewards), infos, np.array(terminated)


@pytest.mark.parametrize("env_id", GOAL_IDS)
def test_observation_keys(make_env, env_id):
    env = make_env(env_id)
    obs, _ = env.reset(seed=0)
    assert list(obs) == ["observation", "achieved_goal", "desired_goal"]
    assert obs["achieved_goal"].shape == obs["desired_goal"].shape == (3,)


@pytest.mark.parametrize("env_id", GOAL_IDS)
def test_batched_compute_reward_matches_step(make_env, env_id):
    env = make_env(env_id, action_mode="ee_delta")
    achieved, desired, rewards, infos, terminated = _rollout(env)
    u = env.unwrapped
    np.testing.assert_array_equal(u.compute_reward(achieved, desired, infos), rewards)
    np.testing.assert_array_equal(u.compute_terminated(achieved, desired, infos), terminated)
    assert u.compute_truncated(achieved, desired, infos).shape == (25,)
    # leading batch dims of any depth
    batch = u.compute_reward(achieved.reshape(5, 5, 3), desired.reshape(5, 5, 3), None)
    np.testing.assert_array_equal(batch, rewards.reshape(5, 5))
    # single samples give plain scalars
    single = u.compute_reward(achieved[0], desired[0], infos[0])
    assert isinstance(single, float) and single == rewards[0]
    assert u.compute_terminated(achieved[0], desired[0], infos[0]) is False
    assert u.compute_truncated(achieved[0], desired[0], infos[0]) is False


def test_sparse_reward_and_success_relabelled(make_env):
    env = make_env("TrossenMujoco/WXAIReachGoal-v0")
    obs, _ = env.reset(seed=1)
    u = env.unwrapped
    a = obs["achieved_goal"]
    assert u.compute_reward(a, a, {}) == 0.0
    assert u.compute_reward(a, a + [0.1, 0, 0], {}) == -1.0
    assert u.compute_reward(np.stack([a, a]), np.stack([a, a + 1]), [{}, {}]).tolist() == [0, -1]


def test_dense_goal_reward_option(make_env):
    env = make_env("TrossenMujoco/WXAIReachGoal-v0", goal_reward_type="dense")
    achieved, desired, rewards, infos, _ = _rollout(env, n=5)
    np.testing.assert_allclose(rewards, -np.linalg.norm(achieved - desired, axis=-1), rtol=1e-6)


def test_terminate_on_success(make_env):
    env = make_env("TrossenMujoco/WXAIReachGoal-v0", terminate_on_success=True)
    obs, _ = env.reset(seed=0)
    a = obs["achieved_goal"]
    assert env.unwrapped.compute_terminated(a, a, {}) is True
    assert env.unwrapped.compute_terminated(
        np.stack([a, a]), np.stack([a, a + 1]), None
    ).tolist() == [True, False]


def test_transfer_cube_is_not_goal_conditioned():
    with pytest.raises(UserError, match="not goal-conditioned.*reach"):
        TrossenMujocoGoalEnv("transfer_cube")


def test_pixels_goal_observation(make_env):
    env = make_env("TrossenMujoco/WXAIReachGoal-v0", obs_type="pixels", width=24, height=20)
    obs, _ = env.reset(seed=0)
    assert obs["observation"].shape == (20, 24, 3) and obs["observation"].dtype == np.uint8
    env = make_env("TrossenMujoco/WXAIPushGoal-v0", obs_type="pixels_state", width=24, height=20)
    obs, _ = env.reset(seed=0)
    assert list(obs) == ["observation", "pixels", "achieved_goal", "desired_goal"]
    assert obs["observation"].dtype == np.float32


def test_a_subclass_compute_reward_scores_the_steps():
    """A goal env subclass with its own compute_reward gets it as the step reward."""

    class Bonus(TrossenMujocoGoalEnv):
        def compute_reward(self, achieved_goal, desired_goal, info):
            return 10.0 + super().compute_reward(achieved_goal, desired_goal, info)

    plain, bonus = TrossenMujocoGoalEnv("reach"), Bonus("reach")
    try:
        plain.reset(seed=3)
        bonus.reset(seed=3)
        rng = np.random.default_rng(0)
        for _ in range(5):
            action = rng.uniform(-1, 1, plain.action_space.shape)
            _, r_plain, _, _, i_plain = plain.step(action)
            _, r_bonus, _, _, i_bonus = bonus.step(action)
            assert r_bonus == r_plain + 10.0
            assert i_bonus["is_success"] == i_plain["is_success"]
    finally:
        plain.close()
        bonus.close()
