"""Recording the single wxai arm's tasks (push, pick_place) with their scripted policies:
``trossen-mujoco record`` writes 7-value episodes (layout ``widowxai``) with the cameras
``overview`` and ``cam``, scored by the task, within the real arm's speed limits."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.collect.joint_policy import make_recorder
from trossen_arm_mujoco.collect.pipeline import RecordSettings
from trossen_arm_mujoco.collect.single_arm import (
    ARM_ACTION_SPEED_LIMITS,
    SingleArmRecorder,
    arm_to_vendor16,
)
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.schema import SINGLE_ARM_LAYOUT
from trossen_arm_mujoco.policies.scripted import ARM_EE
from trossen_arm_mujoco.scripts.record_sim_episodes import cli
from trossen_arm_mujoco.tasks import registry

TASKS = ("push", "pick_place")
H, W = 48, 64


@pytest.mark.parametrize("task", TASKS)
def test_task_entry_declares_its_arm_policy(task):
    entry = registry.load(task)
    policy = entry.policy_class()
    assert policy.action_layout == ARM_EE
    assert policy.minimum_episode_len <= entry.record["episode_len"]
    assert entry.record["cam_names"] == ["overview", "cam"]
    assert task in registry.scripted_names()


@pytest.mark.parametrize("task", TASKS)
def test_record_cli_writes_successful_single_arm_episodes(task, tmp_path, capsys):
    args = ["--task_name", task, "--root_dir", str(tmp_path), "--data_dir", "d"]
    rc = cli([*args, "--num_episodes", "2", "--image_size", f"{H}x{W}"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert out.strip().splitlines()[-1].startswith("Success: 2 / 2")
    T = registry.load(task).record["episode_len"]
    for k in (0, 1):
        ep = load_episode(tmp_path / "d" / f"episode_{k}.hdf5", load_images=True)
        a = ep.attrs
        assert a["task_name"] == task and a["success"] and a["real_replay_checked"]
        assert a["layout"] == SINGLE_ARM_LAYOUT and a["dt"] == pytest.approx(0.02)
        assert list(a["joint_names"]) == [*(f"joint_{i}" for i in range(6)), "left_carriage_joint"]
        assert len(a["goal"]) == 3 and list(a["object_names"]) == ["cube"]
        assert ep.camera_names == ["overview", "cam"]
        for arr in (ep.qpos, ep.qvel, ep.action):
            assert arr.shape == (T, 7)
        assert ep.reward.shape == (T,) and ep.env_state.shape == (T, 7)
        for cam in ("overview", "cam"):
            assert ep.images[cam].shape == (T, H, W, 3) and ep.images[cam].dtype == np.uint8
        assert ep.images["cam"].std() > 0  # something was drawn
        # within the real arm's joint and gripper speed limits at the recording rate
        fps = 1.0 / a["dt"]
        assert np.all(np.abs(np.diff(ep.action, axis=0)) * fps <= ARM_ACTION_SPEED_LIMITS * 1.001)
        assert 0.0 < a["peak_speed_fraction"] <= 1.0 and a["speed_limited_values"] == 0
        # the task scored it: the cube's centre ends within the tolerance of the goal
        tolerance = registry.load(task).load_config()["success_tolerance"]
        assert np.linalg.norm(ep.env_state[-1, :3] - np.asarray(a["goal"])) < tolerance + 0.01


@pytest.mark.parametrize("task", TASKS)
def test_same_seed_same_episode(task, tmp_path):
    settings = RecordSettings(task_name=task, episode_len=40, cam_names=("cam",), height=H, width=W)
    recorder = make_recorder(settings)
    assert isinstance(recorder, SingleArmRecorder)
    try:
        paths = [tmp_path / f"{d}/episode_0.hdf5" for d in "abc"]
        recorder.record(3, paths[0])
        recorder.record(5, paths[2])
        recorder.record(3, paths[1])
    finally:
        recorder.close()
    a, b, c = (load_episode(p, load_images=True) for p in paths)
    for name in ("qpos", "qvel", "action", "reward", "env_state"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(a.images["cam"], b.images["cam"])
    assert a.attrs["seed"] == b.attrs["seed"] != c.attrs["seed"]
    assert not np.array_equal(a.env_state, c.env_state)  # another attempt, another scene


def test_failed_episode_says_the_task_judged_it(tmp_path):
    settings = RecordSettings(task_name="push", episode_len=30)
    recorder = make_recorder(settings)
    try:
        outcome = recorder.record(0, tmp_path / "episode_0.hdf5")
    finally:
        recorder.close()
    assert not outcome.success and outcome.real_replay_checked
    assert outcome.failure() == "the task's success test failed"
    assert load_episode(outcome.path).attrs["success"] is False


def test_arm_rows_for_the_real_replay_check():
    actions = np.arange(14.0).reshape(2, 7)
    rows = arm_to_vendor16(actions)
    assert rows.shape == (2, 16)
    np.testing.assert_array_equal(rows[:, :7], actions)
    np.testing.assert_array_equal(rows[:, 7], actions[:, 6])  # both fingers: the gripper
    np.testing.assert_array_equal(rows[1, 8:], rows[0, :8])  # the other arm holds still


def test_writer_and_reader_take_the_layouts_width(tmp_path):
    from trossen_arm_mujoco.data.io_errors import EpisodeWriteError
    from trossen_arm_mujoco.data.reader import EpisodeError
    from trossen_arm_mujoco.data.writer import EpisodeWriter

    attrs = {"task_name": "push", "seed": 0, "success": True, "layout": SINGLE_ARM_LAYOUT}
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 2, attrs=attrs) as w:
        with pytest.raises(EpisodeWriteError, match=r"expected \(7,\)"):
            w.append(np.zeros(16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7))
        for _ in range(2):
            w.append(np.zeros(7), np.zeros(7), np.zeros(7), 0.0, np.zeros(7))
        with pytest.raises(EpisodeWriteError, match="layout"):
            w.set_attrs(layout="vendor16")
    ep = load_episode(tmp_path / "episode_0.hdf5")
    assert ep.qpos.shape == ep.action.shape == (2, 7)
    import h5py

    with h5py.File(tmp_path / "episode_0.hdf5", "r+") as f:
        del f.attrs["layout"]  # now the rows are too narrow for the kit's 16
    with pytest.raises(EpisodeError, match=r"expected \(T, 16\)"):
        load_episode(tmp_path / "episode_0.hdf5")


def test_plot_of_a_single_arm_episode_names_its_seven_values(tmp_path):
    pytest.importorskip("matplotlib")
    from trossen_arm_mujoco.data.video import joint_labels, plot_joints
    from trossen_arm_mujoco.data.writer import EpisodeWriter

    attrs = {"task_name": "push", "seed": 0, "success": True, "layout": SINGLE_ARM_LAYOUT}
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 3, attrs=attrs) as w:
        for t in range(3):
            w.append(np.full(7, 0.01 * t), np.zeros(7), np.zeros(7), 0.0, np.zeros(7))
    ep = load_episode(tmp_path / "episode_0.hdf5")
    names, units = joint_labels(ep)
    assert len(names) == len(units) == 7 and units[-1] == "m"
    assert plot_joints(ep, tmp_path / "joints.png").stat().st_size > 0
