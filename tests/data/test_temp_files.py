"""Temporary episode files: unique names, and the cleanup of those killed runs left."""

from __future__ import annotations

import os

from trossen_arm_mujoco.data.temp_files import remove_stale_temp_files, unique_temp_path


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def test_unique_temp_path_is_a_hidden_sibling_with_the_pid(tmp_path):
    path = tmp_path / "episode_3.hdf5"
    a, b = unique_temp_path(path), unique_temp_path(path)
    assert a != b and a.parent == b.parent == tmp_path
    assert a.name.startswith(f".episode_3.hdf5.{os.getpid()}-") and a.name.endswith(".tmp")


def test_remove_stale_temp_files(tmp_path, make_episode):
    import subprocess
    import sys

    make_episode(tmp_path / "episode_0.hdf5", num_steps=1, cams=[])
    old_style = tmp_path / ".episode_1.hdf5.tmp"
    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    dead_writer = tmp_path / f".episode_2.hdf5.{int(gone.stdout)}-0a1b2c3d.tmp"
    mine = tmp_path / f".episode_3.hdf5.{os.getpid()}-0a1b2c3d.tmp"
    for path in (old_style, dead_writer, mine):
        path.write_bytes(b"partial")
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:  # a writer that still runs (outside any locked run) keeps its file
        running = tmp_path / f".episode_4.hdf5.{live.pid}-0a1b2c3d.tmp"
        running.write_bytes(b"being written")
        (tmp_path / "notes.tmp").write_text("keep")
        assert remove_stale_temp_files(tmp_path) == [old_style, dead_writer, mine]
        assert _files(tmp_path) == [running.name, "episode_0.hdf5", "notes.tmp"]
    finally:
        live.kill()
        live.wait()
    assert remove_stale_temp_files(tmp_path) == [running]
    assert remove_stale_temp_files(tmp_path / "missing") == []
