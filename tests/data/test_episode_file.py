"""The episode's temporary HDF5 file: rows written in place, published whole (read back,
fsynced, never over a file that appeared meanwhile) or not at all."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.data.episode_file import EpisodeFile
from trossen_arm_mujoco.data.io_errors import EpisodeWriteError
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.schema import ENV_STATE_DIM, SCHEMA
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError

ATTRS = {"task_name": "t", "seed": 1, "box_pose": [0, 0, 0, 1, 0, 0, 0], "success": False}


def _step(cams=()):
    return {
        "qpos": np.zeros(16),
        "qvel": np.zeros(16),
        "action": np.zeros(16),
        "reward": 0.0,
        "env_state": np.array([0, 0, 0, 1, 0, 0, 0.0]),
        "images": {cam: np.zeros((24, 32, 3), np.uint8) for cam in cams},
    }


def _assert_one_line(exc_info):
    assert isinstance(exc_info.value, UserError)
    assert "\n" not in str(exc_info.value)


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def _episode_file(path, steps=2, cams=("cam_a",), compression="gzip") -> EpisodeFile:
    widths = {
        name: (ENV_STATE_DIM,) if spec.variable else spec.width
        for name, spec in zip(SCHEMA.array_names, SCHEMA.arrays, strict=True)
    }
    return EpisodeFile(path, steps, widths, cams, 24, 32, compression, 1, 1, True)


def _rows(t: int) -> dict[str, np.ndarray]:
    return {
        "qpos": np.full(16, t, np.float32),
        "qvel": np.zeros(16, np.float32),
        "action": np.zeros(16, np.float32),
        "reward": np.float32(t),
        "env_state": np.array([0, 0, 0, 1, 0, 0, 0], np.float32),
    }


def test_rows_land_in_place_and_the_file_appears_only_at_commit(tmp_path):
    path = tmp_path / "sub" / "episode_0.hdf5"  # the folder is created
    episode = _episode_file(path)
    frame = np.full((24, 32, 3), 7, np.uint8)
    for t in range(2):
        episode.write_step(t, _rows(t), {"cam_a": frame})
    assert _files(path.parent) == [episode.temp_path.name]
    attrs = {**ATTRS, "episode_len": 2, "camera_names": ["cam_a"], "sim": True, "dt": 0.02}
    episode.commit(attrs, verify=True, overwrite=False)
    assert episode.closed and _files(path.parent) == ["episode_0.hdf5"]
    ep = load_episode(path, load_images=True)
    np.testing.assert_array_equal(ep.qpos[:, 0], [0, 1])
    np.testing.assert_array_equal(ep.images["cam_a"][1], frame)


def test_discard_leaves_nothing_and_is_idempotent(tmp_path):
    episode = _episode_file(tmp_path / "episode_0.hdf5")
    episode.write_step(0, _rows(0), {"cam_a": np.zeros((24, 32, 3), np.uint8)})
    episode.discard()
    episode.discard()
    assert episode.closed and _files(tmp_path) == []


def test_a_file_that_does_not_read_back_is_not_published(tmp_path, monkeypatch):
    from trossen_arm_mujoco.data import reader

    def unreadable(path, load_images=False):
        raise reader.EpisodeError(f"{path}: not a readable HDF5 episode file (truncated?)")

    monkeypatch.setattr(reader, "load_episode", unreadable)
    with pytest.raises(EpisodeWriteError, match="does not read back") as exc_info:
        with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS) as w:
            w.append(**_step(cams=()))
    _assert_one_line(exc_info)
    assert _files(tmp_path) == []
    monkeypatch.undo()
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS, verify=False) as w:
        w.append(**_step(cams=()))
    assert _files(tmp_path) == ["episode_0.hdf5"]


def test_no_clobbering_without_hard_links(tmp_path, monkeypatch):
    """On a file system without hard links the episode is still committed by rename, and a
    file that appeared meanwhile is still never replaced."""

    def no_links(src, dst):
        raise PermissionError("hard links not supported")

    monkeypatch.setattr("trossen_arm_mujoco.fileio.os.link", no_links)
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS) as w:
        w.append(**_step(cams=()))
    assert load_episode(tmp_path / "episode_0.hdf5").num_steps == 1
    path = tmp_path / "episode_1.hdf5"
    with pytest.raises(EpisodeWriteError, match="appeared while writing"):
        with EpisodeWriter(path, 1, attrs=ATTRS) as w:
            w.append(**_step(cams=()))
            path.write_bytes(b"other run")
    assert path.read_bytes() == b"other run"
    assert _files(tmp_path) == ["episode_0.hdf5", "episode_1.hdf5"]


def test_commit_is_flushed_to_disk(tmp_path, monkeypatch):
    """close() fsyncs the episode file before the rename and the folder after it."""
    import os

    from trossen_arm_mujoco import fileio

    synced = []
    monkeypatch.setattr(fileio, "fsync_file", lambda p: synced.append(("file", str(p))))
    monkeypatch.setattr(fileio, "fsync_dir", lambda p: synced.append(("dir", str(p))))
    path = tmp_path / "episode_0.hdf5"
    with EpisodeWriter(path, 1, attrs=ATTRS) as w:
        w.append(**_step(cams=()))
        assert synced == []
    assert synced == [("file", str(w.temp_path)), ("dir", str(tmp_path))]
    assert os.path.exists(path)
