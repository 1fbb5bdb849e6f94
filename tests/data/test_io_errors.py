"""Write failures the file system causes: one-line errors, nothing left behind."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data import chunk_compressor
from trossen_arm_mujoco.data.io_errors import (
    EpisodeIOError,
    folder_io_error,
    io_error,
    os_error_number,
)
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError

REPO = Path(__file__).resolve().parents[2]
ATTRS = {"task_name": "t", "seed": 1, "success": False}
H, W = 24, 32


def _append(w: EpisodeWriter, cams=("cam_a",)) -> None:
    frame = np.full((H, W, 3), 9, np.uint8)
    w.append(np.zeros(16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7), {c: frame for c in cams})


def _one_line(exc: BaseException) -> str:
    assert isinstance(exc, (EpisodeIOError, UserError))
    text = str(exc)
    assert "\n" not in text and "Traceback" not in text
    return text


def test_errno_from_attribute_or_h5py_message():
    assert os_error_number(OSError(errno.ENOSPC, "full")) == errno.ENOSPC
    h5py_text = "Can't decrement id ref count (unable to extend file properly, errno = 28, error"
    assert os_error_number(RuntimeError(h5py_text)) == 28
    assert os_error_number(RuntimeError("something else")) is None


def test_messages_name_file_folder_and_cause(tmp_path):
    err = io_error(tmp_path / "episode_3.hdf5", OSError(errno.ENOSPC, "x\ny"))
    cause = "No space left on device (ENOSPC)"
    assert str(err) == f"cannot write episode_3.hdf5 in {tmp_path}: {cause}"
    assert err.errno == errno.ENOSPC and not err.folder_missing
    gone = tmp_path / "gone"
    err = io_error(gone / "episode_0.hdf5", FileNotFoundError(errno.ENOENT, "x"))
    assert err.folder_missing and "the folder" in str(err) and "removed during the run" in str(err)
    assert str(folder_io_error(tmp_path, PermissionError(errno.EACCES, "no"))).endswith(
        "Permission denied (EACCES)"
    )
    multi = io_error(tmp_path / "e.hdf5", RuntimeError("line one\n line two"))
    assert str(multi).endswith("line one line two")


def _failing_setitem(monkeypatch, after: int, exc: OSError) -> None:
    """h5py dataset writes fail with ``exc`` after ``after`` successful ones."""
    real = h5py.Dataset.__setitem__
    calls = [0]

    def setitem(self, key, value):
        calls[0] += 1
        if calls[0] > after:
            raise exc
        return real(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", setitem)


@pytest.mark.parametrize("compression", ["none", "gzip"])
def test_disk_full_mid_episode(tmp_path, monkeypatch, compression):
    _failing_setitem(monkeypatch, 12, OSError(errno.ENOSPC, "No space left on device"))
    with pytest.raises(EpisodeIOError) as exc_info:
        with EpisodeWriter(
            tmp_path / "episode_0.hdf5", 5, ["cam_a"], H, W, compression=compression, attrs=ATTRS
        ) as w:
            for _ in range(5):
                _append(w)
    text = _one_line(exc_info.value)
    assert text == f"cannot write episode_0.hdf5 in {tmp_path}: No space left on device (ENOSPC)"
    assert os.listdir(tmp_path) == []


def test_disk_full_in_a_background_chunk_write(tmp_path, monkeypatch):
    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(chunk_compressor, "write_chunk", full)
    with pytest.raises(EpisodeIOError, match="No space left on device"):
        with EpisodeWriter(tmp_path / "episode_0.hdf5", 3, ["cam_a"], H, W, attrs=ATTRS) as w:
            for _ in range(3):
                _append(w)
    assert os.listdir(tmp_path) == []


def test_unwritable_folder_when_opening(tmp_path, monkeypatch):
    real = h5py.File

    def refuse(name, mode="r", *args, **kwargs):
        if mode == "w":
            raise PermissionError(errno.EACCES, "Permission denied", str(name))
        return real(name, mode, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", refuse)
    with pytest.raises(EpisodeIOError) as exc_info:
        EpisodeWriter(tmp_path / "episode_0.hdf5", 2, attrs=ATTRS)
    assert _one_line(exc_info.value).endswith("Permission denied (EACCES)")
    assert os.listdir(tmp_path) == []


def test_read_only_file_system_at_commit(tmp_path, monkeypatch):
    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr("trossen_arm_mujoco.fileio.os.link", read_only)
    monkeypatch.setattr("trossen_arm_mujoco.fileio.os.replace", read_only)
    with pytest.raises(EpisodeIOError) as exc_info:
        with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS) as w:
            _append(w, cams=())
    assert _one_line(exc_info.value).endswith("Read-only file system (EROFS)")
    assert os.listdir(tmp_path) == []


def test_folder_removed_mid_episode_is_reported_not_recreated(tmp_path):
    folder = tmp_path / "d"
    folder.mkdir()
    with pytest.raises(EpisodeIOError) as exc_info:
        with EpisodeWriter(
            folder / "episode_0.hdf5", 3, ["cam_a"], H, W, attrs=ATTRS, create_folder=False
        ) as w:
            _append(w)
            shutil.rmtree(folder)
            _append(w)
            _append(w)
    assert exc_info.value.folder_missing
    assert "removed during the run" in _one_line(exc_info.value)
    assert not folder.exists()
    with pytest.raises(EpisodeIOError, match="removed during the run"):
        EpisodeWriter(folder / "episode_1.hdf5", 1, attrs=ATTRS, create_folder=False)
    assert not folder.exists()


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_FSIZE, SIGXFSZ")
@pytest.mark.parametrize("compression", ["none", "gzip"])
def test_real_write_failure_from_the_os(tmp_path, compression):
    """A real refused write (file size limit: EFBIG from write(2)) through h5py: one-line
    error, no file left, and the process exits cleanly (HDF5 cannot flush such a file; one
    left open crashes the interpreter at exit)."""
    script = textwrap.dedent(f"""
        import resource, signal
        import numpy as np
        from trossen_arm_mujoco.data.io_errors import EpisodeIOError
        from trossen_arm_mujoco.data.writer import EpisodeWriter
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))
        rng = np.random.default_rng(0)
        try:
            with EpisodeWriter({str(tmp_path / "episode_0.hdf5")!r}, 40, ["a"], 48, 64,
                               compression={compression!r}, attrs={ATTRS!r}) as w:
                for _ in range(40):
                    img = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
                    w.append(np.zeros(16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7),
                             {{"a": img}})
        except EpisodeIOError as exc:
            print(exc)
    """)
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=60
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == (
        f"cannot write episode_0.hdf5 in {tmp_path}: File too large (EFBIG)"
    )
    assert proc.stderr == ""
    assert os.listdir(tmp_path) == []


def test_finished_episode_survives_a_later_failure(tmp_path, monkeypatch):
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 2, ["cam_a"], H, W, attrs=ATTRS) as w:
        _append(w)
        _append(w)
    _failing_setitem(monkeypatch, 3, OSError(errno.ENOSPC, "No space left on device"))
    with pytest.raises(EpisodeIOError):
        with EpisodeWriter(tmp_path / "episode_1.hdf5", 2, ["cam_a"], H, W, attrs=ATTRS) as w:
            _append(w)
            _append(w)
    monkeypatch.undo()
    assert os.listdir(tmp_path) == ["episode_0.hdf5"]
    assert load_episode(tmp_path / "episode_0.hdf5").num_steps == 2
