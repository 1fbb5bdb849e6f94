"""Dataset runs: workers, resume, skip_failed."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.collect.parallel import (
    DatasetRecorder,
    failure_summary,
    format_size,
    plan_run,
)
from trossen_arm_mujoco.collect.pipeline import EpisodeOutcome, RecordSettings
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


def _outcome(final: float, checked: bool = True) -> EpisodeOutcome:
    success = final == 4.0 and checked
    return EpisodeOutcome(0, 0, success, final, final, None, 4.0, checked)


def test_failure_summary_says_how_many_and_why():
    failed = [_outcome(2.0), _outcome(3.0)]
    assert failure_summary(failed, 3, "episodes", 300, 440) == (
        "2 of 3 episodes failed: reward below max 4 (episode_len 300 < 440 the scripted "
        "policy needs)"
    )
    assert failure_summary(failed, 3, "episodes", 600, 440) == (
        "2 of 3 episodes failed: reward below max 4"
    )
    mixed = [_outcome(2.0), _outcome(4.0, checked=False), _outcome(1.0)]
    assert failure_summary(mixed, 5, "attempts", 600, 440) == (
        "3 of 5 attempts failed: 2 reward below max 4, 1 actions fail the real-arm speed check"
    )
    assert failure_summary([], 3, "episodes", 300, 440) == ""
    assert _outcome(4.0).failure() is None


def test_report_lists_failures_and_sizes(tmp_path):
    report = _run(tmp_path, 2)  # 30 steps: both fail
    assert [o.failure() for o in report.failed] == ["reward below max 4"] * 2
    sizes = [(tmp_path / f"episode_{k}.hdf5").stat().st_size for k in (0, 1)]
    assert [o.nbytes for o in report.saved] == sizes and report.saved_bytes == sum(sizes)


def test_format_size():
    assert [format_size(n) for n in (999, 44_300, 97_100_000, 2_212_296_072)] == [
        "999 B", "44.3 kB", "97.1 MB", "2.212 GB",
    ]  # fmt: skip
