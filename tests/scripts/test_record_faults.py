"""``record`` when the file system refuses a write: disk full, unwritable or read-only
folder, folder removed mid-run. One ``error:`` line naming the cause and the complete
episodes, a non-zero exit, no temporary or partial file, finished episodes intact."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.scripts.record_sim_episodes import cli

REPO = Path(__file__).resolve().parents[2]
STEPS = 20
#: 3 short state-only episodes; each step writes 5 datasets (qpos, qvel, action, reward,
#: env_state), so dataset write number 5 * STEPS + 50 falls in the middle of episode 1.
ARGS = ["--num_episodes", "3", "--episode_len", str(STEPS), "--cam_names", "none"]
MID_EPISODE_1 = 5 * STEPS + 50


def _record(tmp_path, capsys, *extra):
    rc = cli(["--data_dir", "d", "--root_dir", str(tmp_path), *ARGS, *extra])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _error_line(err: str) -> str:
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, err
    assert err.strip().splitlines()[-1] == errors[0]  # the run ends with it
    assert "Traceback" not in err
    return errors[0]


def _only_episode_0(folder: Path) -> None:
    assert sorted(os.listdir(folder)) == ["episode_0.hdf5"]  # no temp, no staging
    assert load_episode(folder / "episode_0.hdf5").num_steps == STEPS


def _fail_writes_after(monkeypatch, count: int, exc: OSError) -> None:
    real = h5py.Dataset.__setitem__
    calls = [0]

    def setitem(self, key, value):
        calls[0] += 1
        if calls[0] > count:
            raise exc
        return real(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", setitem)


@pytest.mark.parametrize("skip_failed", [False, True])
def test_disk_full_mid_run(tmp_path, capsys, monkeypatch, skip_failed):
    _fail_writes_after(monkeypatch, MID_EPISODE_1, OSError(errno.ENOSPC, "No space left"))
    if skip_failed:  # short episodes fail: make a final reward of 0 the task's maximum
        from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder

        real_init = EpisodeRecorder.__init__

        def init(self, *args, **kwargs):
            real_init(self, *args, **kwargs)
            self.max_reward = 0.0

        monkeypatch.setattr(EpisodeRecorder, "__init__", init)
    rc, out, err = _record(tmp_path, capsys, *(["--skip_failed"] if skip_failed else []))
    line = _error_line(err)
    assert rc == 2
    folder = tmp_path / "d"
    where = folder / ".staging" if skip_failed else folder
    name = "attempt_1.hdf5" if skip_failed else "episode_1.hdf5"
    assert line == (
        f"error: cannot write {name} in {where}: No space left on device (ENOSPC); "
        f"complete episodes: episode 0 in {folder}; free disk space or choose another "
        "--root_dir, then rerun to continue"
    )
    assert "episode 0: " in out and "Success" not in out
    monkeypatch.undo()
    _only_episode_0(folder)


def test_unwritable_folder_mid_run(tmp_path, capsys, monkeypatch):
    """The folder stops accepting new files after episode 0 (root ignores chmod, so the
    refusal is simulated where the writer creates its file)."""
    real = h5py.File
    opened = [0]

    def refuse_second(name, mode="r", *args, **kwargs):
        if mode == "w":
            opened[0] += 1
            if opened[0] > 1:
                raise PermissionError(errno.EACCES, "Permission denied", str(name))
        return real(name, mode, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", refuse_second)
    rc, _, err = _record(tmp_path, capsys)
    line = _error_line(err)
    assert rc == 2
    assert "cannot write episode_1.hdf5" in line and "Permission denied (EACCES)" in line
    assert "complete episodes: episode 0" in line and "permissions" in line
    monkeypatch.undo()
    _only_episode_0(tmp_path / "d")


def test_read_only_file_system_mid_run(tmp_path, capsys, monkeypatch):
    import trossen_arm_mujoco.fileio as fileio

    real_link = fileio.os.link
    links = [0]

    def link_once(src, dst):
        links[0] += 1
        if links[0] > 1:
            raise OSError(errno.EROFS, "Read-only file system")
        return real_link(src, dst)

    monkeypatch.setattr(fileio.os, "link", link_once)
    monkeypatch.setattr(
        fileio.os, "replace", lambda *a: (_ for _ in ()).throw(OSError(errno.EROFS, "ro"))
    )
    rc, _, err = _record(tmp_path, capsys)
    assert rc == 2
    assert "Read-only file system (EROFS)" in _error_line(err)
    monkeypatch.undo()
    _only_episode_0(tmp_path / "d")


def test_folder_removed_mid_run(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "d"
    real = EpisodeWriter.append
    calls = [0]

    def append(self, *args, **kwargs):
        calls[0] += 1
        if calls[0] == STEPS + 5:  # inside episode 1
            shutil.rmtree(folder)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(EpisodeWriter, "append", append)
    rc, out, err = _record(tmp_path, capsys)
    assert rc == 2
    assert _error_line(err) == (
        f"error: cannot write episode_1.hdf5: the folder {folder} was removed during the "
        "run; complete episodes: none (the folder is gone); rerun to record again"
    )
    assert not folder.exists()  # reported, not silently recreated
    assert "episode 0: " in out


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_FSIZE, SIGXFSZ")
def test_real_file_size_limit_with_two_workers(tmp_path):
    """A real refused write (EFBIG from write(2), RLIMIT_FSIZE) inside worker processes."""

    def limit():
        import resource
        import signal

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (30_000, 30_000))

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.scripts.record_sim_episodes",
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--num_episodes",
            "2",
            "--episode_len",
            "20",
            "--cam_names",
            "cam_high",
            "--image_size",
            "48x64",
            "--compression",
            "none",
            "--num_workers",
            "2",
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=180,
        preexec_fn=limit,
    )
    assert proc.returncode == 2, proc.stderr[-2000:]
    line = _error_line(proc.stderr)
    assert "File too large (EFBIG)" in line and "complete episodes: none" in line
    assert os.listdir(tmp_path / "d") == []
