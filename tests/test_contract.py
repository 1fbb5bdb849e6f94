"""The contract every registered task and gym env keeps.

Tasks: sample, step, finite observations within their bounds, ``score`` equal to
``get_reward``/``get_info``, same seed -> same episode, different seeds differ. Envs (every
id, every action mode): create, reset, step, spaces, no NaN, observations inside their space,
the flat vector (and the goals) equal to the task's dict observation at every step, the Box
bounds equal to the task's bounds, same seed + same actions -> identical trajectory,
different seeds differ. A task written with only its observation parts (``TipHeightTask``
below, registered for the test) keeps the same contract in the gym env and the goal env.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

from typing import Any, ClassVar  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import trossen_arm_mujoco  # noqa: E402,F401
from trossen_arm_mujoco.gym.actions import ACTION_MODES  # noqa: E402
from trossen_arm_mujoco.gym.registration import ENV_IDS, TaskEnvSpec  # noqa: E402
from trossen_arm_mujoco.tasks import registry  # noqa: E402
from trossen_arm_mujoco.tasks.observation import Part  # noqa: E402
from trossen_arm_mujoco.tasks.reach import ReachSampler  # noqa: E402
from trossen_arm_mujoco.tasks.sampler import uniform  # noqa: E402
from trossen_arm_mujoco.tasks.task import Task  # noqa: E402

N_STEPS = 15


def _flat(obs) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate([np.asarray(v, float).ravel() for v in obs.values()])
    return np.asarray(obs, float).ravel()


def _as_in_space(values: list[np.ndarray], box: gym.spaces.Box) -> np.ndarray:
    """The float32 vector of ``values`` clipped into ``box`` (what the env must give)."""
    vec = np.concatenate([np.asarray(v, float).ravel() for v in values]).astype(np.float32)
    return np.clip(vec, box.low, box.high)


def _check_vector_is_the_dict(env: gym.Env, obs: Any) -> None:
    """The env's state vector (and goals) hold the task's dict observation (then goal and
    goal delta in the plain env), clipped into the space, in the order of its bounds."""
    u = env.unwrapped
    task = u.task
    values = list(task.get_observation().values())
    if u.goal_env:
        space = u.observation_space
        np.testing.assert_array_equal(
            obs["observation"], _as_in_space(values, space["observation"])
        )
        for key, want in (
            ("achieved_goal", task.achieved_goal()),
            ("desired_goal", task.desired_goal()),
        ):
            np.testing.assert_array_equal(obs[key], _as_in_space([want], space[key]))
        return
    if task.goal_conditioned:
        desired = task.desired_goal()
        values += [desired, desired - task.achieved_goal()]
    np.testing.assert_array_equal(obs, _as_in_space(values, u.observation_space))


def _check_bounds_are_the_tasks(env: gym.Env) -> None:
    """The state Box is the task's observation bounds (then goal bounds) in order."""
    u = env.unwrapped
    task = u.probe
    bounds = list(task.observation_bounds().values())
    if task.goal_conditioned:
        g_low, g_high = task.goal_bounds()
        goal_box = gym.spaces.Box(g_low.astype(np.float32), g_high.astype(np.float32))
        if u.goal_env:
            for key in ("achieved_goal", "desired_goal"):
                assert u.observation_space[key] == goal_box
        else:
            bounds += [(g_low, g_high), (g_low - g_high, g_high - g_low)]
    box = u.observation_space["observation"] if u.goal_env else u.observation_space
    np.testing.assert_array_equal(
        box.low, np.concatenate([b[0] for b in bounds]).astype(np.float32)
    )
    np.testing.assert_array_equal(
        box.high, np.concatenate([b[1] for b in bounds]).astype(np.float32)
    )


def _rollout(env: gym.Env, seed: int, actions: np.ndarray) -> list[np.ndarray]:
    obs, info = env.reset(seed=seed)
    assert env.observation_space.contains(obs)
    _check_vector_is_the_dict(env, obs)
    trajectory = [_flat(obs)]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        assert env.observation_space.contains(obs), obs
        _check_vector_is_the_dict(env, obs)
        assert np.isfinite(reward)
        assert isinstance(terminated, bool) and isinstance(truncated, bool)
        assert isinstance(info["is_success"], bool)
        assert isinstance(info["safety_clipped"], bool)
        trajectory.append(np.append(_flat(obs), reward))
    return trajectory


def _env_contract(env: gym.Env) -> None:
    space = env.action_space
    assert isinstance(space, gym.spaces.Box) and space.dtype == np.float32
    assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
    for box in _boxes(env.observation_space):
        assert np.all(np.isfinite(box.low)) and np.all(np.isfinite(box.high))
        assert np.all(box.low < box.high)
    _check_bounds_are_the_tasks(env)
    actions = np.random.default_rng(0).uniform(-1, 1, (N_STEPS, *space.shape))
    first = _rollout(env, 5, actions)
    second = _rollout(env, 5, actions)
    for a, b in zip(first, second, strict=True):
        assert np.all(np.isfinite(a))
        np.testing.assert_array_equal(a, b)
    other = _rollout(env, 6, actions)
    assert not np.array_equal(first[0], other[0])
    assert not env.unwrapped.scene.warnings()


@pytest.mark.parametrize("action_mode", ACTION_MODES)
@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_env_contract(env_id, action_mode):
    env = gym.make(env_id, action_mode=action_mode)
    try:
        _env_contract(env)
    finally:
        env.close()


def _boxes(space: gym.Space) -> list[gym.spaces.Box]:
    if isinstance(space, gym.spaces.Dict):
        return [b for s in space.spaces.values() for b in _boxes(s)]
    assert isinstance(space, gym.spaces.Box)
    return [space]


def _task_contract(name: str) -> None:
    sampler = registry.make_sampler(name)
    try:
        episodes = []
        for seed in (1, 1, 2):
            task = sampler.sample_task(seed)
            bounds = task.observation_bounds()
            assert list(bounds) == list(task.observed.names)
            states = []
            for _ in range(5):
                obs, reward, done = task.step({})
                assert np.isfinite(reward) and not done
                assert task.score() == (float(reward), task.get_info())  # the gym env's scoring
                assert list(obs) == list(bounds)
                for key, value in obs.items():
                    low, high = bounds[key]
                    assert value.dtype == np.float64 and value.shape == low.shape, key
                    assert np.all(np.isfinite(value)), key
                    assert np.all(value >= low - 1e-9) and np.all(value <= high + 1e-9), key
                np.testing.assert_array_equal(  # the gym vector's pieces hold the dict
                    np.concatenate(task.observed.values()), np.concatenate(list(obs.values()))
                )
                states.append(np.concatenate(list(obs.values())))
            assert isinstance(task.judge_success(), bool)
            episodes.append(np.array(states))
        np.testing.assert_array_equal(episodes[0], episodes[1])
        assert not np.array_equal(episodes[0], episodes[2])
    finally:
        sampler.close()


@pytest.mark.parametrize("name", registry.names())
def test_task_contract(name):
    _task_contract(name)


# --- a task written the README's way: only its observation parts -----------------------------
class TipHeightTask(Task):
    """Hold the wxai tool frame at a target height (m above the world origin).

    Its observation, said once: the arm's joint positions (a live view of ``qpos``), the
    tool frame's height (a live view of one ``site_xpos`` value) and the norm of the arm's
    joint velocities (computed). Goal-conditioned on the height (1 value): achieved = the
    height part, desired = the task's target.
    """

    name: ClassVar[str] = "test_tip_height"
    robot_name: ClassVar[str] = "wxai"
    goal_conditioned: ClassVar[bool] = True

    def __init__(self, scene, config, target: float = 0.2):
        super().__init__(scene, config)
        self.arm = self.robot.view.get_move_group("arm")
        self.target = np.array([target])  # (1,) m
        self.tolerance = float(self.config["success_tolerance"])

    def observation_parts(self) -> list[Part]:
        data, arm = self.data, self.arm
        q, qd = arm.state_views(data)
        tip = arm.frame_position_view(data)
        return [
            Part("joints", q, arm.joint_range[:, 0], arm.joint_range[:, 1]),
            Part("tip_height", tip[2:3], -0.5, 1.0),
            Part("joint_speed", lambda: np.array([np.sqrt(qd.dot(qd))]), 0.0, 50.0),  # rad/s
        ]

    def goal_parts(self) -> tuple[Part, Part]:
        return self.observed["tip_height"], Part("target", self.target, -0.5, 1.0)

    def goal_success(self, achieved, desired):
        return np.abs(np.asarray(achieved)[..., 0] - np.asarray(desired)[..., 0]) < self.tolerance

    def goal_reward(self, achieved, desired):
        return -np.abs(np.asarray(achieved, float)[..., 0] - np.asarray(desired, float)[..., 0])

    def get_reward(self) -> float:
        return float(self.goal_reward(self.achieved_goal(), self.desired_goal()))

    def judge_success(self) -> bool:
        return bool(self.goal_success(self.achieved_goal(), self.desired_goal()))

    def get_task_description(self) -> str:
        return f"hold the gripper tip {self.target[0]:.3f} m high"


class TipHeightSampler(ReachSampler):
    """Reach's scene and initial joints; a target height uniform in [0.1, 0.3] m."""

    task_cls = TipHeightTask

    def _sample_task(self, scene):
        self.perturb_arm(self.rng)
        return self.task_cls(scene, self.config, target=uniform(self.rng, 0.1, 0.3))


TIP_IDS = {
    "TrossenMujocoTest/TipHeight-v0": "trossen_arm_mujoco.gym.env:TrossenMujocoEnv",
    "TrossenMujocoTest/TipHeightGoal-v0": "trossen_arm_mujoco.gym.goal_env:TrossenMujocoGoalEnv",
}


@pytest.fixture
def tip_height(monkeypatch):
    """``TipHeightTask`` registered (task registry and gym ids) for one test, then removed."""
    entry = registry.TaskEntry(
        TipHeightTask.name,
        f"{__name__}:TipHeightTask",
        f"{__name__}:TipHeightSampler",
        "reach",
        "test: hold the tool frame at a height",
        keys=registry.load("reach").keys,  # the keys of the config it borrows
    )
    monkeypatch.setitem(registry.TASKS, entry.name, entry)
    for env_id, entry_point in TIP_IDS.items():
        spec = TaskEnvSpec(
            id=env_id, entry_point=entry_point, kwargs={"task": entry.name}, task=entry.name
        )
        monkeypatch.setitem(gym.registry, env_id, spec)
    yield entry.name
    # monkeypatch removes the entry and the ids after the test


def test_a_task_with_only_observation_parts_keeps_the_contract(tip_height):
    _task_contract(tip_height)
    sampler = registry.make_sampler(tip_height)
    try:
        task = sampler.sample_task(0)
        assert [p.live for p in task.observed] == [True, True, False]
        assert task.goal_bounds()[0].shape == (1,)
    finally:
        sampler.close()
    for env_id in TIP_IDS:
        for action_mode in ("joint_position", "ee_delta"):
            env = gym.make(env_id, action_mode=action_mode)
            try:
                _env_contract(env)
            finally:
                env.close()
    goal_env = gym.make("TrossenMujocoTest/TipHeightGoal-v0")
    try:
        obs, _ = goal_env.reset(seed=0)
        assert obs["achieved_goal"].shape == obs["desired_goal"].shape == (1,)
        u = goal_env.unwrapped
        for _ in range(3):
            obs, reward, _, _, info = goal_env.step(goal_env.action_space.sample())
            achieved, desired = obs["achieved_goal"], obs["desired_goal"]
            assert reward == u.compute_reward(achieved, desired, info)
            assert info["is_success"] == bool(u.task.goal_success(achieved, desired))
        batch = u.compute_reward(np.zeros((4, 1)), np.full((4, 1), 0.1), None)
        np.testing.assert_allclose(batch, np.full(4, -0.1))
    finally:
        goal_env.close()


def test_the_test_task_is_gone_after_its_test():
    assert TipHeightTask.name not in registry.names()
    assert not any(env_id in gym.registry for env_id in TIP_IDS)


# --- every task with a scripted policy, through the recorder and the dm_control envs -----
@pytest.mark.parametrize("name", registry.scripted_names())
def test_scripted_task_records_a_short_state_only_episode(name, tmp_path):
    from trossen_arm_mujoco.collect.joint_policy import make_recorder
    from trossen_arm_mujoco.collect.pipeline import RecordSettings
    from trossen_arm_mujoco.data.reader import load_episode

    recorder = make_recorder(RecordSettings(task_name=name, episode_len=20))
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
@pytest.mark.parametrize(
    "name", [n for n in registry.scripted_names() if n in registry.kit_names()]
)  # the dm_control envs are the Stationary AI kit's (the Mobile AI's task has none)
def test_scripted_task_dm_control_env(name, flavour):
    from trossen_arm_mujoco.tasks.dm_tasks import dm_task_class
    from trossen_arm_mujoco.utils import make_sim_env

    def rollout(seed):
        env = make_sim_env(dm_task_class(name, flavour), task_name=name, cam_list=[], random=seed)
        try:
            ts = env.reset()
            first = ts.observation["env_state"].copy()
            hold = (
                np.concatenate(
                    [
                        ts.observation["mocap_pose_left"],
                        [0.044],
                        ts.observation["mocap_pose_right"],
                        [0.044],
                    ]
                )
                if flavour == "ee"
                else ts.observation["qpos"]
            )
            rewards = []
            for _ in range(5):
                ts = env.step(hold)
                assert np.all(np.isfinite(ts.observation["qpos"]))
                task_obs = env.task.task.get_observation()  # the registered task's dict
                for key in ("qpos", "env_state"):
                    np.testing.assert_array_equal(ts.observation[key], task_obs[key])
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
