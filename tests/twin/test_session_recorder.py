"""Client sessions of a served kit recorded as episodes (in this process, no network: the
sessions are announced as the servers would, the world is stepped without pacing)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT
from trossen_arm_mujoco.twin.kit_world import KitWorld
from trossen_arm_mujoco.twin.session_recorder import RecordOptions, SessionRecorder
from trossen_arm_mujoco.twin.spool_recovery import recover_spools


def session(world: KitWorld, recorder: SessionRecorder, seconds: float, move: float = 0.0):
    """One client session of ``seconds``: the left arm's joint_0 target moves by ``move``."""
    recorder.session_started()
    world.advance(0.02)
    world.arms["left"].target[0] += move
    world.advance(seconds - 0.02)
    recorder.session_ended()
    world.advance(0.02)  # the next frame ends the episode and resets the world


def test_one_episode_per_session_with_images_reward_and_actions(tmp_path: Path) -> None:
    world = KitWorld("sim_transfer_cube", base_seed=3, episode_index=4)
    lines: list[str] = []
    options = RecordOptions(tmp_path, ("cam_high",), 48, 64)
    recorder = SessionRecorder(world, options, first_index=4, say=lines.append)
    start_poses = world.env_state()
    world.advance(0.1)  # no client: nothing recorded
    session(world, recorder, 0.4, move=0.2)
    session(world, recorder, 0.2)
    stats = recorder.stop()
    world.close()
    assert [i for i, _ in list_episodes(tmp_path)] == [4, 5]
    first = load_episode(tmp_path / "episode_4.hdf5", load_images=True)
    assert first.num_steps == 20 and first.camera_names == ["cam_high"]
    assert first.images["cam_high"].shape == (20, 48, 64, 3)
    assert first.images["cam_high"].std() > 0  # a rendered scene, not a blank frame
    assert first.reward is not None and first.reward.shape == (20,)
    attrs = first.attrs
    assert attrs["seed"] == episode_seed(3, 4) and attrs["attempt"] == 4
    assert attrs["end_reason"] == "session ended" and attrs["source"] == "serve"
    assert not attrs["success"] and attrs["task_name"] == "sim_transfer_cube"
    np.testing.assert_allclose(attrs["initial_env_state"], start_poses, atol=0.02)
    action = first.action
    assert action[0, 0] == pytest.approx(0.0, abs=1e-6) and action[-1, 0] == pytest.approx(0.2)
    np.testing.assert_array_equal(action[:, 6], action[:, 7])  # gripper in both fingers
    second = load_episode(tmp_path / "episode_5.hdf5")
    assert second.num_steps == 10 and second.attrs["seed"] == episode_seed(3, 5)
    # the second session started from a fresh scene: the arm back at its start
    assert second.qpos[0, VENDOR16_LAYOUT.arm("left")][0] == pytest.approx(0.0, abs=0.01)
    assert len(stats.written) == 2 and not stats.errors
    assert lines[0].startswith("episode_4.hdf5: 20 steps (0.40 s), session ended; reward")
    assert not list(tmp_path.glob(".*.tmp"))  # no spool or temporary file left


def test_episode_len_splits_a_session_and_moves_only_the_objects(tmp_path: Path) -> None:
    world = KitWorld("sim_transfer_cube", base_seed=0)
    recorder = SessionRecorder(world, RecordOptions(tmp_path, episode_len=5), 0, say=print)
    recorder.session_started()
    world.advance(0.02)
    world.arms["right"].target[0] = -0.3
    world.advance(0.5)  # 26 frames: 5 episodes of 5, the sixth under way
    arm = world.measured("right")[0]
    stats = recorder.stop()  # writes the episode under way
    world.close()
    found = [i for i, _ in list_episodes(tmp_path)]
    assert found == [0, 1, 2, 3, 4, 5] and len(stats.written) == 6
    eps = [load_episode(tmp_path / f"episode_{i}.hdf5") for i in found]
    assert [e.num_steps for e in eps[:5]] == [5] * 5 and eps[5].num_steps == 1
    assert eps[5].attrs["end_reason"] == "serve stopped"
    assert eps[1].attrs["end_reason"] == "5 steps (--episode_len)"
    # arms carry on across the split, the cube moves to the next episode's sampled pose
    assert eps[4].qpos[-1, 8] == pytest.approx(arm, abs=0.05)
    assert not np.allclose(eps[1].attrs["initial_env_state"], eps[2].attrs["initial_env_state"])


def test_an_existing_file_is_never_overwritten(tmp_path: Path) -> None:
    world = KitWorld("sim_transfer_cube")
    lines: list[str] = []
    recorder = SessionRecorder(world, RecordOptions(tmp_path), 0, say=lines.append)
    (tmp_path / "episode_0.hdf5").write_bytes(b"not mine")  # appears after the run began
    session(world, recorder, 0.1)
    stats = recorder.stop()
    world.close()
    assert (tmp_path / "episode_0.hdf5").read_bytes() == b"not mine"
    assert stats.errors and "refusing to overwrite" in stats.errors[0]
    assert lines[-1].startswith("error: episode_0.hdf5 was not written")
    # the steps are not lost: the spool is kept, and the next run publishes it
    [kept] = stats.kept
    assert f"steps are kept in {kept}" in lines[-1] and kept.exists()
    left = kept.with_name(f".serve_spool.{_dead_pid()}-00.tmp")  # as after this run ended
    kept.rename(left)
    [result] = recover_spools(tmp_path, lambda: 1, lines.append)
    assert result.episode == tmp_path / "episode_1.hdf5" and not left.exists()
    episode = load_episode(result.episode)
    assert episode.num_steps == 5 and episode.attrs["source"] == "serve"
    assert episode.attrs["end_reason"].startswith("recovered")


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid
