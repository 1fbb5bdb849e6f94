"""Dataset runs: workers, a worker killed mid-attempt, interrupts, resume (failed episodes,
gaps, other settings, unreadable files), skip_failed."""

from __future__ import annotations

import os
import shutil
import signal
import threading
import time
from dataclasses import replace

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.collect.parallel import (
    STAGING,
    DatasetRecorder,
    failure_summary,
    format_size,
)
from trossen_arm_mujoco.collect.pipeline import EpisodeOutcome, EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.collect.resume import plan_run
from trossen_arm_mujoco.data.dataset_lock import read_holder
from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.errors import UserError

#: 30 steps are far too short for the scripted transfer: every episode fails.
SETTINGS = RecordSettings(episode_len=30, cam_names=("cam_high",), height=16, width=16)
#: 440 steps: the shortest the scripted transfer needs; these succeed.
SUCCEEDS_STATE = RecordSettings(episode_len=440)
#: State only, long enough to catch a worker in the middle of an attempt.
STATE_200 = RecordSettings(episode_len=200)


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


def test_resume_continues_after_the_last_success(tmp_path):
    _run(tmp_path, 1, settings=SUCCEEDS_STATE)
    before = (tmp_path / "episode_0.hdf5").stat().st_mtime_ns
    report = _run(tmp_path, 2, settings=SUCCEEDS_STATE)
    assert [o.attempt for o in report.saved] == [1] and report.saved_at == [1]
    assert (tmp_path / "episode_0.hdf5").stat().st_mtime_ns == before
    fresh = tmp_path / "fresh"
    _run(fresh, 2, settings=SUCCEEDS_STATE)
    _same(tmp_path / "episode_1.hdf5", fresh / "episode_1.hdf5")


def test_overwrite_starts_afresh(tmp_path):
    _run(tmp_path, 1)
    report = _run(tmp_path, 1, overwrite=True)
    assert [o.attempt for o in report.saved] == [0]


def test_failed_episodes_are_recorded_again_with_fresh_attempts(tmp_path):
    report = _run(tmp_path, 2)  # 30 steps: both fail, both kept
    assert report.failed_indices == [0, 1]
    assert [load_episode(p).attrs["success"] for _, p in list_episodes(tmp_path)] == [False] * 2
    plan = plan_run(tmp_path, 3, settings=SETTINGS)
    assert (plan.indices, plan.attempts, plan.failed) == ([0, 1, 2], [3, 4, 2], [0, 1])
    report = _run(tmp_path, 3)
    assert [(o.attempt, k) for o, k in zip(report.saved, report.saved_at)] == [
        (3, 0),
        (4, 1),
        (2, 2),
    ]
    assert [load_episode(p).attrs["attempt"] for _, p in list_episodes(tmp_path)] == [3, 4, 2]


def test_a_gap_is_filled_with_the_attempt_of_a_clean_run(tmp_path):
    clean, holed = tmp_path / "clean", tmp_path / "holed"
    _run(clean, 3, settings=SUCCEEDS_STATE)
    shutil.copytree(clean, holed)
    (holed / "episode_1.hdf5").unlink()
    plan = plan_run(holed, 5, settings=SUCCEEDS_STATE)
    assert (plan.indices, plan.attempts, plan.gaps) == ([1, 3, 4], [1, 3, 4], [1])
    report = _run(holed, 3, settings=SUCCEEDS_STATE)
    assert report.saved_at == [1]
    _same(clean / "episode_1.hdf5", holed / "episode_1.hdf5")


@pytest.fixture(scope="module")
def one_failed(tmp_path_factory):
    """A folder with one (failed) episode of SETTINGS."""
    folder = tmp_path_factory.mktemp("one")
    _run(folder, 1)
    return folder


def test_resume_refuses_an_unreadable_episode(tmp_path, one_failed):
    shutil.copytree(one_failed, tmp_path, dirs_exist_ok=True)
    (tmp_path / "episode_1.hdf5").write_bytes(b"half written")
    with pytest.raises(UserError) as exc_info:
        plan_run(tmp_path, 3, settings=SETTINGS)
    message = str(exc_info.value)
    assert message.startswith(f"episode_1.hdf5 in {tmp_path} is not a readable episode (")
    assert message.endswith(
        "move it out of the folder (or delete it) and rerun: the episode index is recorded again"
    )
    assert "\n" not in message


@pytest.mark.parametrize(
    "change, differs",
    [
        ({"base_seed": 5}, "--seed 0 (this run: 5)"),
        ({"episode_len": 31}, "--episode_len 30 (this run: 31)"),
        ({"cam_names": ()}, "--cam_names cam_high (this run: none)"),
        ({"height": 8}, "--image_size 16x16 (this run: 8x16)"),
        ({"task_name": "sim_insertion"}, "--task_name sim_transfer_cube (this run: sim_insertion)"),
        ({"inject_noise": True}, "--inject_noise not set (this run: set)"),
        ({"randomize": True}, "--randomize not set (this run: set)"),
    ],
)
def test_resume_refuses_other_settings_naming_the_flag(tmp_path, one_failed, change, differs):
    shutil.copytree(one_failed, tmp_path, dirs_exist_ok=True)
    with pytest.raises(UserError) as exc_info:
        plan_run(tmp_path, 2, settings=replace(SETTINGS, **change))
    assert str(exc_info.value) == (
        f"{tmp_path} holds episodes recorded with other settings than this run "
        f"(episode_0.hdf5: {differs}); rerun with the dataset's flags to continue it, or "
        "choose another --data_dir for a new dataset (--overwrite replaces its episodes)"
    )
    plan_run(tmp_path, 2, overwrite=True, settings=replace(SETTINGS, **change))


def test_a_run_holds_the_folder(tmp_path):
    """While a run records, the folder's lock file names it; afterwards nothing is left."""
    seen = []

    def log(line: str) -> None:
        seen.append(read_holder(tmp_path)[0])

    DatasetRecorder(SETTINGS, tmp_path, log=log).run(1)
    assert seen == [os.getpid()]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episode_0.hdf5"]


def test_killed_worker_is_replaced_and_the_dataset_is_unchanged(tmp_path):
    """A real ``kill -9`` of the worker process writing an attempt: the attempt runs again in
    a new worker, the run finishes, and the files equal those of a clean run."""
    folder = tmp_path / "killed"
    killed: list[int] = []
    warnings: list[str] = []
    done = threading.Event()

    def kill_a_writer() -> None:
        while not done.is_set():
            for tmp in (folder / STAGING).glob(".attempt_1.hdf5.*.tmp"):
                pid = int(tmp.name.split(".")[3].split("-")[0])
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.005)

    watcher = threading.Thread(target=kill_a_writer)
    watcher.start()
    try:
        report = DatasetRecorder(
            STATE_200, folder, num_workers=2, log=lambda s: None, warn=warnings.append
        ).run(3)
    finally:
        done.set()
        watcher.join()
    assert len(killed) == 1, "no worker was caught writing attempt 1"
    assert warnings == [
        f"warning: worker process {killed[0]} running attempt 1 died (killed by SIGKILL, out "
        "of memory?); running attempt 1 again (try 2 of 3)"
    ]
    assert not report.interrupted and report.io_error is None
    assert [o.attempt for o in report.saved] == [0, 1, 2]
    assert sorted(p.name for p in folder.iterdir()) == [f"episode_{k}.hdf5" for k in range(3)]
    clean = tmp_path / "clean"
    _run(clean, 3, settings=STATE_200)
    for k in range(3):
        _same(clean / f"episode_{k}.hdf5", folder / f"episode_{k}.hdf5")


class _OutOfOrder(DatasetRecorder):
    """An engine whose attempt 2 finishes while attempt 1 still runs, then Ctrl-C."""

    def _execute(self, jobs, report):
        self._staging()
        recorder = EpisodeRecorder(self.settings)
        try:
            for job in (jobs[0], jobs[2]):
                outcome = recorder.record(job.attempt, job.path, job.overwrite)
                self._deliver(job, outcome, report)
        finally:
            recorder.close()
        raise KeyboardInterrupt


def test_interrupt_publishes_every_finished_attempt_and_resume_completes(tmp_path):
    folder = tmp_path / "d"
    report = _OutOfOrder(SUCCEEDS_STATE, folder, num_workers=2, log=lambda s: None).run(3)
    assert report.interrupted and report.saved_at == [0, 2]
    assert sorted(p.name for p in folder.iterdir()) == ["episode_0.hdf5", "episode_2.hdf5"]
    report = _run(folder, 3, settings=SUCCEEDS_STATE)
    assert [(o.attempt, k) for o, k in zip(report.saved, report.saved_at)] == [(1, 1)]
    clean = tmp_path / "clean"
    _run(clean, 3, settings=SUCCEEDS_STATE)
    for k in range(3):
        _same(clean / f"episode_{k}.hdf5", folder / f"episode_{k}.hdf5")


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


def test_skip_failed_replaces_a_failed_episode_with_a_success(tmp_path):
    _run(tmp_path, 2, settings=SUCCEEDS_STATE)
    with h5py.File(tmp_path / "episode_0.hdf5", "r+") as f:  # as if episode 0 had failed
        f.attrs["success"] = False
    rec = DatasetRecorder(SUCCEEDS_STATE, tmp_path, skip_failed=True, log=lambda s: None)
    report = rec.run(2)
    assert [(o.attempt, o.success) for o in report.saved] == [(2, True)]
    assert report.saved_at == [0]
    episode = load_episode(tmp_path / "episode_0.hdf5")
    assert episode.attrs["attempt"] == 2 and episode.attrs["success"] is True


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
        "999 B",
        "44.3 kB",
        "97.1 MB",
        "2.212 GB",
    ]
