"""The contract every registered task and gym env keeps.

Tasks: sample, step, finite observations within their bounds, ``score`` equal to
``get_reward``/``get_info``, same seed -> same episode, different seeds differ. Envs (every
id, every action mode): create, reset, step, spaces, no NaN, observations inside their space,
same seed + same actions -> identical trajectory, different seeds differ.
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


def _check_state_parts(task, obs: dict) -> None:
    """``state_parts`` (the gym state vector's pieces, live views) hold the values of
    ``get_observation`` (then the goal and goal delta), where the task has the shortcut."""
    for with_goal in (False, True) if task.goal_conditioned else (False,):
        parts = task.state_parts(with_goal)
        if parts is None:
            continue
        want = list(obs.values())
        if with_goal:
            want += [task.desired_goal(), task.desired_goal() - task.achieved_goal()]
        np.testing.assert_array_equal(np.concatenate(parts), np.concatenate(want))


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
                assert task.score() == (float(reward), task.get_info())  # the gym env's scoring
                _check_state_parts(task, obs)
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


# --- every task with a scripted policy, through the recorder and the dm_control envs -----
@pytest.mark.parametrize("name", registry.scripted_names())
def test_scripted_task_records_a_short_state_only_episode(name, tmp_path):
    from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings
    from trossen_arm_mujoco.data.reader import load_episode

    recorder = EpisodeRecorder(RecordSettings(task_name=name, episode_len=20))
    try:
        outcomes = [recorder.record(0, tmp_path / f"{d}/episode_0.hdf5") for d in "ab"]
        outcomes.append(recorder.record(1, tmp_path / "c/episode_0.hdf5"))
    finally:
        recorder.close()
    eps = [load_episode(o.path) for o in outcomes]
    for ep in eps:
        assert ep.attrs["task_name"] == name and ep.attrs["real_replay_checked"]
        for arr in (ep.qpos, ep.qvel, ep.action, ep.env_state):
            assert arr.shape[0] == 20 and np.all(np.isfinite(arr))
        assert ep.env_state.shape[1] == 7 * len(ep.attrs["object_names"])
    np.testing.assert_array_equal(eps[0].action, eps[1].action)  # same attempt, same episode
    assert not np.array_equal(eps[0].env_state, eps[2].env_state)  # another attempt differs


@pytest.mark.parametrize("flavour", ["ee", "joint"])
@pytest.mark.parametrize("name", registry.scripted_names())
def test_scripted_task_dm_control_env(name, flavour):
    from trossen_arm_mujoco.tasks.dm_tasks import dm_task_class
    from trossen_arm_mujoco.utils import make_sim_env

    def rollout(seed):
        env = make_sim_env(dm_task_class(name, flavour), task_name=name, cam_list=[], random=seed)
        try:
            ts = env.reset()
            first = ts.observation["env_state"].copy()
            hold = (
                np.concatenate([ts.observation["mocap_pose_left"], [0.044],
                                ts.observation["mocap_pose_right"], [0.044]])
                if flavour == "ee" else ts.observation["qpos"]
            )  # fmt: skip
            rewards = []
            for _ in range(5):
                ts = env.step(hold)
                assert np.all(np.isfinite(ts.observation["qpos"]))
                rewards.append(ts.reward)
            assert env.task.max_reward == registry.load(name).task_class().max_reward
            return first, ts.observation["qpos"].copy(), rewards
        finally:
            env.task.close()

    a, b, c = rollout(3), rollout(3), rollout(4)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2] == b[2] and all(r == 0 for r in a[2])
    assert not np.array_equal(a[0], c[0])
