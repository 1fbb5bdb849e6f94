"""The contract every registered task and gym env keeps.

Tasks: sample, step, finite observations within their bounds, same seed -> same episode,
different seeds differ. Envs (every id, every action mode): create, reset, step, spaces,
no NaN, observations inside their space, same seed + same actions -> identical trajectory,
different seeds differ.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import trossen_arm_mujoco  # noqa: E402,F401
from trossen_arm_mujoco.gym.actions import ACTION_MODES  # noqa: E402
from trossen_arm_mujoco.gym.registration import ENV_IDS  # noqa: E402
from trossen_arm_mujoco.tasks import registry  # noqa: E402

N_STEPS = 15


def _flat(obs) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate([np.asarray(v, float).ravel() for v in obs.values()])
    return np.asarray(obs, float).ravel()


def _rollout(env: gym.Env, seed: int, actions: np.ndarray) -> list[np.ndarray]:
    obs, info = env.reset(seed=seed)
    assert env.observation_space.contains(obs)
    trajectory = [_flat(obs)]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        assert env.observation_space.contains(obs), obs
        assert np.isfinite(reward)
        assert isinstance(terminated, bool) and isinstance(truncated, bool)
        assert isinstance(info["is_success"], bool)
        assert isinstance(info["safety_clipped"], bool)
        trajectory.append(np.append(_flat(obs), reward))
    return trajectory


@pytest.mark.parametrize("action_mode", ACTION_MODES)
@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_env_contract(env_id, action_mode):
    env = gym.make(env_id, action_mode=action_mode)
    try:
        space = env.action_space
        assert isinstance(space, gym.spaces.Box) and space.dtype == np.float32
        assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
        for box in _boxes(env.observation_space):
            assert np.all(np.isfinite(box.low)) and np.all(np.isfinite(box.high))
            assert np.all(box.low < box.high)
        actions = np.random.default_rng(0).uniform(-1, 1, (N_STEPS, *space.shape))
        first = _rollout(env, 5, actions)
        second = _rollout(env, 5, actions)
        for a, b in zip(first, second, strict=True):
            assert np.all(np.isfinite(a))
            np.testing.assert_array_equal(a, b)
        other = _rollout(env, 6, actions)
        assert not np.array_equal(first[0], other[0])
        assert not env.unwrapped.scene.warnings()
    finally:
        env.close()


def _boxes(space: gym.Space) -> list[gym.spaces.Box]:
    if isinstance(space, gym.spaces.Dict):
        return [b for s in space.spaces.values() for b in _boxes(s)]
    assert isinstance(space, gym.spaces.Box)
    return [space]


@pytest.mark.parametrize("name", registry.names())
def test_task_contract(name):
    sampler = registry.make_sampler(name)
    try:
        episodes = []
        for seed in (1, 1, 2):
            task = sampler.sample_task(seed)
            bounds = task.observation_bounds()
            states = []
            for _ in range(5):
                obs, reward, done = task.step({})
                assert np.isfinite(reward) and not done
                for key, value in obs.items():
                    low, high = bounds[key]
                    assert np.all(np.isfinite(value)), key
                    assert np.all(value >= low - 1e-9) and np.all(value <= high + 1e-9), key
                states.append(np.concatenate(list(obs.values())))
            assert isinstance(task.judge_success(), bool)
            episodes.append(np.array(states))
        np.testing.assert_array_equal(episodes[0], episodes[1])
        assert not np.array_equal(episodes[0], episodes[2])
    finally:
        sampler.close()
