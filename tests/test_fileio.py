"""Atomic writes: a temporary sibling, fsync, rename; nothing partial ever under the name,
whatever the signal; folder locks and the removal of stale temporary files."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from trossen_arm_mujoco import fileio
from trossen_arm_mujoco.data.schema import temp_file_name
from trossen_arm_mujoco.fileio import atomic_path, publish, temp_path, write_bytes, write_text


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_temp_path_is_a_hidden_sibling_matching_the_episode_convention(tmp_path):
    path = tmp_path / "episode_3.hdf5"
    assert temp_path(path) == tmp_path / ".episode_3.hdf5.tmp"
    assert temp_path(path).name == temp_file_name(path.name)
    assert temp_path("a/b.png") == Path("a/.b.png.tmp")


def test_atomic_path_publishes_on_success(tmp_path):
    target = tmp_path / "out.txt"
    with atomic_path(target) as tmp:
        assert tmp == tmp_path / ".out.txt.tmp"
        tmp.write_text("done")
        assert not target.exists()  # nothing under the final name before the block ends
    assert target.read_text() == "done"
    assert _names(tmp_path) == ["out.txt"]


@pytest.mark.parametrize("error", [OSError("disk full"), KeyboardInterrupt()])
def test_error_in_block_removes_temp_and_keeps_old_file(tmp_path, error):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(type(error)):
        with atomic_path(target) as tmp:
            tmp.write_text("partial")
            raise error
    assert target.read_text() == "old"
    assert _names(tmp_path) == ["out.txt"]


def test_block_that_writes_nothing_fails_and_leaves_nothing(tmp_path):
    with pytest.raises(FileNotFoundError):
        with atomic_path(tmp_path / "never.txt"):
            pass
    assert _names(tmp_path) == []


def test_overwrite_false_refuses_and_removes_temp(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(FileExistsError, match="refusing to overwrite"):
        with atomic_path(target, overwrite=False) as tmp:
            tmp.write_text("new")
    assert target.read_text() == "old"
    assert _names(tmp_path) == ["out.txt"]


def test_overwrite_true_replaces(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    assert write_text(target, "new") == target
    assert target.read_text() == "new"
    assert _names(tmp_path) == ["out.txt"]


def test_publish_without_overwrite_keeps_src_when_dst_exists(tmp_path):
    src, dst = tmp_path / "src", tmp_path / "dst"
    src.write_text("new")
    dst.write_text("old")
    with pytest.raises(FileExistsError):
        publish(src, dst)
    assert dst.read_text() == "old" and src.read_text() == "new"  # the caller decides


def test_publish_moves_and_leaves_no_second_link(tmp_path):
    src, dst = tmp_path / "src", tmp_path / "dst"
    src.write_bytes(b"abc")
    assert publish(src, dst) == dst
    assert _names(tmp_path) == ["dst"]
    assert dst.read_bytes() == b"abc" and os.stat(dst).st_nlink == 1


def test_publish_falls_back_to_rename_without_hard_links(tmp_path, monkeypatch):
    def no_links(src, dst):
        raise PermissionError("hard links not supported")

    monkeypatch.setattr(fileio.os, "link", no_links)
    src, dst = tmp_path / "src", tmp_path / "dst"
    src.write_text("new")
    publish(src, dst)
    assert _names(tmp_path) == ["dst"] and dst.read_text() == "new"
    src.write_text("newer")
    with pytest.raises(FileExistsError):  # still no clobbering
        publish(src, dst)
    assert dst.read_text() == "new"


def test_fsync_flushes_file_and_folder(tmp_path, monkeypatch):
    synced: list[str] = []
    real_fsync = os.fsync

    def fsync(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        real_fsync(fd)

    if not Path("/proc/self/fd").is_dir():
        pytest.skip("needs /proc to name file descriptors")
    monkeypatch.setattr(fileio.os, "fsync", fsync)
    write_bytes(tmp_path / "a.bin", b"x")
    assert synced == [str(tmp_path / ".a.bin.tmp"), str(tmp_path)]
    synced.clear()
    with atomic_path(tmp_path / "b.bin", fsync=False) as tmp:
        tmp.write_bytes(b"y")
    assert synced == []


def test_write_text_is_utf8(tmp_path):
    write_text(tmp_path / "t.txt", "joint_0 — 0.5 rad\n")
    assert (tmp_path / "t.txt").read_bytes() == "joint_0 — 0.5 rad\n".encode()


# -- signals, locks, stale temporary files ---------------------------------------------------


def _signal_self(sig: int) -> None:
    os.kill(os.getpid(), sig)
    for _ in range(1000):  # a Python handler runs at the next bytecode
        pass


def test_deferred_signals_hold_ctrl_c_until_the_block_ends():
    steps = []
    with pytest.raises(KeyboardInterrupt):
        with fileio.deferred_signals():
            _signal_self(signal.SIGINT)
            steps.append("after the signal")  # still runs: the block is not cut in half
    assert steps == ["after the signal"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_deferred_signals_deliver_to_the_handler_in_place():
    seen = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    try:
        with fileio.deferred_signals():
            _signal_self(signal.SIGTERM)
            _signal_self(signal.SIGTERM)
            assert seen == []
        assert seen == [signal.SIGTERM]  # delivered once, after the block
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_publish_is_not_cut_in_half_by_a_signal(tmp_path, monkeypatch):
    """Ctrl-C between the hard link and the unlink of the temporary file: both happen, then
    the interrupt is raised; no second name of the file is left behind."""
    real_link = os.link

    def link_then_signal(src, dst):
        real_link(src, dst)
        _signal_self(signal.SIGINT)

    monkeypatch.setattr(fileio.os, "link", link_then_signal)
    src, dst = tmp_path / ".out.txt.tmp", tmp_path / "out.txt"
    src.write_text("done")
    with pytest.raises(KeyboardInterrupt):
        publish(src, dst)
    assert dst.read_text() == "done"
    assert _names(tmp_path) == ["out.txt"]


def test_a_second_signal_does_not_skip_the_cleanup(tmp_path, monkeypatch):
    real_unlink = Path.unlink

    def signal_then_unlink(self, missing_ok=False):
        _signal_self(signal.SIGINT)  # Ctrl-C pressed again while cleaning up
        real_unlink(self, missing_ok=missing_ok)

    with pytest.raises(KeyboardInterrupt):
        with atomic_path(tmp_path / "out.txt") as tmp:
            tmp.write_text("partial")
            monkeypatch.setattr(Path, "unlink", signal_then_unlink)
            raise OSError("disk full")
    monkeypatch.undo()
    assert _names(tmp_path) == []


def test_folder_lock_is_exclusive_and_released(tmp_path):
    with fileio.folder_lock(tmp_path) as folder:
        assert folder == tmp_path
        with pytest.raises(fileio.FolderBusyError, match="in use by another process"):
            with fileio.folder_lock(tmp_path):
                pass
    with fileio.folder_lock(tmp_path):  # free again
        pass
    assert _names(tmp_path) == []  # nothing left behind


def test_folder_lock_held_by_another_process(tmp_path):
    code = (
        "import sys, time; from trossen_arm_mujoco.fileio import folder_lock\n"
        "with folder_lock(sys.argv[1]):\n    print('locked', flush=True); time.sleep(60)\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline() == "locked\n"
        with pytest.raises(fileio.FolderBusyError):
            with fileio.folder_lock(tmp_path):
                pass
    finally:
        proc.kill()  # like SIGKILL of a run: the OS releases the lock
        proc.wait()
    with fileio.folder_lock(tmp_path):
        pass


def test_remove_stale_temps_removes_only_matching_temporaries(tmp_path):
    (tmp_path / ".episode_0.mp4.tmp").write_bytes(b"partial video")
    (tmp_path / ".episode_12_joints.png.tmp").write_bytes(b"partial plot")
    (tmp_path / ".ds.tmp").mkdir()
    (tmp_path / ".ds.tmp" / "data.parquet").write_bytes(b"x")
    keep = [
        ".episode_3.hdf5.tmp",  # the recorder's: not this command's
        "episode_0.mp4",  # a finished file
        ".episode_x.mp4.tmp",  # not a name the pattern allows
        ".episode_1.mp4",  # hidden but not temporary
    ]
    for name in keep:
        (tmp_path / name).write_bytes(b"keep")
    removed = fileio.remove_stale_temps(tmp_path, r"episode_\d+(\.mp4|_joints\.png)")
    assert sorted(p.name for p in removed) == [".episode_0.mp4.tmp", ".episode_12_joints.png.tmp"]
    assert fileio.remove_stale_temps(tmp_path, "ds") == [tmp_path / ".ds.tmp"]
    assert _names(tmp_path) == sorted(keep)
    assert fileio.remove_stale_temps(tmp_path / "missing", "ds") == []
