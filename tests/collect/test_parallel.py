"""Dataset runs: workers, resume, skip_failed."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.collect.parallel import DatasetRecorder, plan_run
from trossen_arm_mujoco.collect.pipeline import RecordSettings
from trossen_arm_mujoco.data.reader import list_episodes, load_episode

SETTINGS = RecordSettings(episode_len=30, cam_names=("cam_high",), height=16, width=16)


def _run(folder, n, workers=1, skip_failed=False, overwrite=False, settings=SETTINGS):
    rec = DatasetRecorder(
        settings,
        folder,
        num_workers=workers,
        skip_failed=skip_failed,
        overwrite=overwrite,
        log=lambda s: None,
    )
    return rec.run(n, plan_run(folder, n, overwrite))


def _same(a, b):
    ea = load_episode(a, load_images=True)
    eb = load_episode(b, load_images=True)
    for name in ("qpos", "qvel", "action", "reward", "env_state"):
        np.testing.assert_array_equal(getattr(ea, name), getattr(eb, name))
    for cam in ea.camera_names:
        np.testing.assert_array_equal(ea.images[cam], eb.images[cam])
    assert ea.attrs.keys() == eb.attrs.keys()
    for key in ea.attrs:
        np.testing.assert_array_equal(np.asarray(ea.attrs[key]), np.asarray(eb.attrs[key]))


def test_one_and_two_workers_give_identical_datasets(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    _run(one, 3, workers=1)
    _run(two, 3, workers=2)
    assert [k for k, _ in list_episodes(one)] == [0, 1, 2]
    assert [k for k, _ in list_episodes(two)] == [0, 1, 2]
    for k in range(3):
        _same(one / f"episode_{k}.hdf5", two / f"episode_{k}.hdf5")


def test_resume_continues_after_highest_index(tmp_path):
    _run(tmp_path, 1)
    before = (tmp_path / "episode_0.hdf5").stat().st_mtime_ns
    report = _run(tmp_path, 2)
    assert [o.attempt for o in report.saved] == [1]
    assert (tmp_path / "episode_0.hdf5").stat().st_mtime_ns == before
    fresh = tmp_path / "fresh"
    _run(fresh, 2)
    _same(tmp_path / "episode_1.hdf5", fresh / "episode_1.hdf5")


def test_overwrite_starts_afresh(tmp_path):
    _run(tmp_path, 1)
    report = _run(tmp_path, 1, overwrite=True)
    assert [o.attempt for o in report.saved] == [0]


def test_skip_failed_is_bounded_and_reported(tmp_path):
    # 30 steps are far too short to transfer the cube: every attempt fails
    settings = RecordSettings(episode_len=30)
    rec = DatasetRecorder(settings, tmp_path, skip_failed=True, log=lambda s: None)
    report = rec.run(1, plan_run(tmp_path, 1, False))
    assert report.attempts == rec.max_attempts(1) == 13
    assert report.saved == []
    assert list_episodes(tmp_path) == []
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())


def test_skip_failed_keeps_only_successes(tmp_path):
    settings = RecordSettings(episode_len=600)
    rec = DatasetRecorder(settings, tmp_path, skip_failed=True, log=lambda s: None)
    report = rec.run(2, plan_run(tmp_path, 2, False))
    assert len(report.saved) == 2 and all(o.success for o in report.saved)
    assert [k for k, _ in list_episodes(tmp_path)] == [0, 1]
    assert load_episode(tmp_path / "episode_1.hdf5").attrs["success"]
