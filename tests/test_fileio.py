"""Atomic writes: a temporary sibling, fsync, rename; nothing partial ever under the name."""

from __future__ import annotations

import os
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
