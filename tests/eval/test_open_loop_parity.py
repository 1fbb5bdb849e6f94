"""Open-loop parity: a recorded episode's actions, replayed in the evaluation env from the
episode's initial state, succeed, for every seed and both kit tasks.

This is what makes recorded data train reliable policies: ``trossen-mujoco eval`` and
LeRobot's env plugin run ``KitPolicyEnv``; if the very actions of a successful recording did
not succeed there, no policy imitating them could. Episodes are recorded state-only with the
recording pipeline (``EpisodeRecorder.record``, as ``trossen-mujoco record --cam_names none``
does) into HDF5 files, read back with the reader, and replayed:

- at the recording rate (50 fps): the stored actions in the kit14 layout; the env's arms
  must also follow the recorded trajectory (they trail it: the env sends each action
  through the driver's trajectory, as the real kit takes it);
- at the export rate of 30 fps: the actions resampled exactly as ``trossen-mujoco export
  --fps 30`` writes them (``export.lerobot.frame_values``), in the env at ``fps=30``
  (physics at 1/510 s), which is what a policy trained on a 30 fps export is evaluated in.

The env is put into the recorded initial state with ``reset(options={"object_poses": ...})``
from the file's ``object_names`` / ``initial_env_state`` attributes; the arms start at the
task's home pose in both. A control test checks that success is not vacuous: the same
actions with an object moved 6 cm fail.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.data.reader import Episode, load_episode
from trossen_arm_mujoco.eval.env import KitPolicyEnv
from trossen_arm_mujoco.export.lerobot import frame_values
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT
from trossen_arm_mujoco.tasks import registry

TASKS = ("sim_transfer_cube", "sim_insertion")
#: Base seed of the recordings (``record --seed``) and the attempts replayed.
BASE_SEED = 26
ATTEMPTS = (0, 1, 2)
#: Recording rate (the tasks' policy_dt = 0.02 s) and the export rate tested.
NATIVE_FPS = 50
EXPORT_FPS = 30
#: Largest deviation (m, rad) from the recorded trajectory at the recording rate: the files
#: store float32, the physics is the same.
TRAJECTORY_ATOL = 1e-5
#: How closely the env, driving the arms through the driver's trajectory, follows the
#: recorded trajectory (rad, m): median and largest joint deviation, largest object one
#: (measured: 1e-4 .. 1e-3, 0.05 .. 0.10, 0.005).
FOLLOW_MEDIAN, FOLLOW_MAX, OBJECTS_MAX = 0.005, 0.15, 0.02


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Path]]:
    """Task -> the HDF5 files of attempts ``ATTEMPTS`` recorded state-only (full length)."""
    root = tmp_path_factory.mktemp("parity")
    files: dict[str, list[Path]] = {}
    for task in TASKS:
        settings = RecordSettings(
            task_name=task,
            episode_len=int(registry.load(task).record["episode_len"]),
            base_seed=BASE_SEED,
        )
        recorder = EpisodeRecorder(settings)
        try:
            files[task] = [
                recorder.record(k, root / task / f"episode_{k}.hdf5").path for k in ATTEMPTS
            ]
        finally:
            recorder.close()
    return files


@pytest.fixture
def make_env():
    """``make_env(task, **kwargs)``: a state-only KitPolicyEnv closed at teardown."""
    envs: list[KitPolicyEnv] = []

    def make(task: str, **kwargs) -> KitPolicyEnv:
        env = KitPolicyEnv(task, render_mode=None, **kwargs)
        envs.append(env)
        return env

    yield make
    for env in envs:
        env.close()


def initial_poses(episode: Episode) -> dict[str, np.ndarray]:
    """The recorded initial object poses: name -> (7,) [xyz m, quat wxyz]."""
    names = list(episode.attrs["object_names"])
    state = np.asarray(episode.attrs["initial_env_state"], dtype=float).reshape(len(names), 7)
    return dict(zip(names, state))


def replay(env: KitPolicyEnv, actions: np.ndarray, poses: dict, seed: int) -> list[dict]:
    """Reset ``env`` to ``poses`` and step the ``(K, 14)`` actions open loop; returns the
    raw observation of the episode (16-value qpos, env_state) after every step and the
    final info as the last entry's ``info``."""
    env.reset(seed=seed, options={"object_poses": poses})
    trace = []
    info: dict = {}
    for action in actions:
        _, _, terminated, _, info = env.step(action)
        assert not terminated
        obs = env.task.get_observation()
        trace.append({"qpos": obs["qpos"].copy(), "env_state": obs["env_state"].copy()})
    trace[-1]["info"] = info
    return trace


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("attempt", ATTEMPTS)
def test_recorded_actions_succeed_open_loop_at_the_recording_rate(
    recordings, make_env, task, attempt
):
    episode = load_episode(recordings[task][ATTEMPTS.index(attempt)])
    assert episode.attrs["success"], f"the recording itself failed: {episode.attrs}"
    assert round(1.0 / episode.dt) == NATIVE_FPS
    env = make_env(task, episode_length=episode.num_steps)
    poses = initial_poses(episode)

    obs, _ = env.reset(seed=attempt, options={"object_poses": poses})
    # the same initial state: the arms at the recorded start, the objects at the recorded poses
    np.testing.assert_allclose(
        obs["agent_pos"], KIT14_LAYOUT.from_vendor(episode.qpos[0]), atol=TRAJECTORY_ATOL
    )
    np.testing.assert_allclose(obs["environment_state"], episode.env_state[0], atol=1e-7)

    actions = KIT14_LAYOUT.from_vendor(episode.action)  # the env's kit14 layout
    trace = replay(env, actions, poses, seed=attempt)
    info = trace[-1]["info"]
    assert info["is_success"], (
        f"{task} attempt {attempt}: recorded actions reach stage {info['stage']} of "
        f"{env.max_reward} open loop (recorded final reward {episode.attrs['final_reward']})"
    )
    # observation t + 1 of the file is the state after action t
    qpos = np.array([s["qpos"] for s in trace[:-1]])
    env_state = np.array([s["env_state"] for s in trace[:-1]])
    # the env sends each action as the real kit takes it (the driver's trajectory toward the
    # goal over 3 periods, grippers opened to the controller's 0.04 m): the arms trail the
    # recorded motion by about two periods, and follow it
    lag = np.abs(qpos - episode.qpos[1:])
    print(
        f"{task} {attempt}: qpos deviation median {np.median(lag):.2e}, max {lag.max():.3f}; "
        f"objects max {np.abs(env_state - episode.env_state[1:]).max():.3f}"
    )
    assert np.median(lag) < FOLLOW_MEDIAN and lag.max() < FOLLOW_MAX
    assert np.abs(env_state - episode.env_state[1:]).max() < OBJECTS_MAX


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("attempt", ATTEMPTS)
def test_exported_30fps_actions_succeed_open_loop_at_30fps(recordings, make_env, task, attempt):
    episode = load_episode(recordings[task][ATTEMPTS.index(attempt)])
    values = frame_values(episode, layout="kit14", fps=EXPORT_FPS)  # as export --fps 30
    actions = values["action"]
    assert actions.shape == (episode.num_steps * EXPORT_FPS // NATIVE_FPS, 14)
    env = make_env(task, fps=EXPORT_FPS)
    assert env.episode_length == len(actions)  # the default length: every exported frame
    poses = initial_poses(episode)

    obs, _ = env.reset(seed=attempt, options={"object_poses": poses})
    np.testing.assert_allclose(obs["agent_pos"], values["observation.state"][0], atol=1e-6)
    np.testing.assert_allclose(
        obs["environment_state"], values["observation.environment_state"][0], atol=1e-7
    )
    info = replay(env, actions, poses, seed=attempt)[-1]["info"]
    assert info["is_success"], (
        f"{task} attempt {attempt}: exported 30 fps actions reach stage {info['stage']} of "
        f"{env.max_reward} open loop at 30 fps"
    )


@pytest.mark.parametrize("task", TASKS)
def test_moving_an_object_makes_the_same_actions_fail(recordings, make_env, task):
    """Control: success above depends on the initial state (not vacuous)."""
    episode = load_episode(recordings[task][0])
    env = make_env(task, episode_length=episode.num_steps)
    actions = KIT14_LAYOUT.from_vendor(episode.action)
    for name in episode.attrs["object_names"]:
        poses = initial_poses(episode)
        poses[name][1] += 0.06  # 6 cm along y
        info = replay(env, actions, poses, seed=0)[-1]["info"]
        assert not info["is_success"], f"{task}: success with {name} moved 6 cm"
