"""Streaming atomic writer: round trips, atomicity, validation."""

from __future__ import annotations

import os
import tracemalloc

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data.io_errors import EpisodeWriteError
from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError

H, W = 24, 32
ATTRS = {"task_name": "t", "seed": 1, "box_pose": [0, 0, 0, 1, 0, 0, 0], "success": False}


def _step(cams=("cam_a",), h=H, w=W):
    return {
        "qpos": np.zeros(16),
        "qvel": np.zeros(16),
        "action": np.zeros(16),
        "reward": 0.0,
        "env_state": np.array([0, 0, 0, 1, 0, 0, 0.0]),
        "images": {cam: np.zeros((h, w, 3), np.uint8) for cam in cams},
    }


def _assert_one_line(exc_info):
    assert isinstance(exc_info.value, UserError)
    assert "\n" not in str(exc_info.value)


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("compression", ["none", "gzip", "lzf"])
def test_round_trip(tmp_path, make_episode, compression):
    path = tmp_path / "episode_7.hdf5"
    data = make_episode(path, num_steps=5, compression=compression, seed=7)
    assert _files(tmp_path) == ["episode_7.hdf5"]
    ep = load_episode(path, load_images=True)
    assert ep.num_steps == 5 and ep.index == 7 and not ep.is_vendor
    for name in ("qpos", "qvel", "action", "reward", "env_state"):
        got = getattr(ep, name)
        assert got.dtype == np.float64  # the reader hands out float64 ...
        np.testing.assert_array_equal(got, data[name].astype(np.float32))  # ... of float32
    assert ep.camera_names == ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]
    for cam, images in data["images"].items():
        np.testing.assert_array_equal(ep.images[cam], images)
        np.testing.assert_array_equal(ep.read_frame(cam, 3), images[3])
    assert ep.attrs["seed"] == 7 and ep.attrs["success"] is True
    assert ep.attrs["task_name"] == "sim_transfer_cube"
    np.testing.assert_allclose(ep.box_pose, [0.01, -0.15, 0.0125, 1, 0, 0, 0])
    with h5py.File(path, "r") as f:
        expected = None if compression == "none" else compression
        assert f["observations/images/cam_high"].compression == expected


def test_camera_order_follows_writer(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=2, cams=["zeta", "alpha"])
    assert load_episode(path).camera_names == ["zeta", "alpha"]


def test_accepts_float32_and_lists(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with EpisodeWriter(path, 1, [], attrs=ATTRS) as w:
        w.append(np.ones(16, np.float32), [0.5] * 16, np.arange(16), np.float32(2), [0] * 7)
    ep = load_episode(path)
    assert ep.qpos.dtype == np.float64 and ep.qpos[0, 0] == 1.0
    assert ep.reward.tolist() == [2.0]


def test_exception_mid_episode_leaves_nothing(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with (
        pytest.raises(RuntimeError, match="boom"),
        EpisodeWriter(path, 4, ["cam_a"], H, W, attrs=ATTRS) as w,
    ):
        w.append(**_step())
        assert w.temp_path.exists() and w.temp_path.parent == tmp_path
        assert list_episodes(tmp_path) == []
        raise RuntimeError("boom")
    assert _files(tmp_path) == []


def test_keyboard_interrupt_leaves_nothing(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with pytest.raises(KeyboardInterrupt), EpisodeWriter(path, 4, attrs=ATTRS) as w:
        w.append(**_step(cams=()))
        raise KeyboardInterrupt
    assert _files(tmp_path) == []


def test_incomplete_episode_is_discarded(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with pytest.raises(EpisodeWriteError, match="only 1 of 3 steps") as exc_info:
        with EpisodeWriter(path, 3, attrs=ATTRS) as w:
            w.append(**_step(cams=()))
    _assert_one_line(exc_info)
    assert _files(tmp_path) == []


def test_missing_attrs_at_close_is_discarded(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with pytest.raises(EpisodeWriteError, match="missing attributes") as exc_info:
        with EpisodeWriter(path, 1, attrs={"task_name": "t"}) as w:
            w.append(**_step(cams=()))
    _assert_one_line(exc_info)
    assert "seed" in str(exc_info.value) and "success" in str(exc_info.value)
    assert _files(tmp_path) == []


def test_refuses_to_overwrite(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=2, cams=[], seed=1)
    before = path.read_bytes()
    with pytest.raises(EpisodeWriteError, match="already exists") as exc_info:
        make_episode(path, num_steps=2, cams=[], seed=2)
    _assert_one_line(exc_info)
    assert path.read_bytes() == before
    assert _files(tmp_path) == ["episode_0.hdf5"]
    make_episode(path, num_steps=3, cams=[], seed=2, overwrite=True)
    assert load_episode(path).num_steps == 3


def test_refuses_file_that_appears_while_writing(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    with pytest.raises(EpisodeWriteError, match="appeared while writing"):
        with EpisodeWriter(path, 1, attrs=ATTRS) as w:
            w.append(**_step(cams=()))
            path.write_bytes(b"other run")
    assert path.read_bytes() == b"other run"
    assert _files(tmp_path) == ["episode_0.hdf5"]


@pytest.mark.parametrize(
    "change, message",
    [
        ({"qpos": np.zeros(15)}, r"qpos has shape \(15,\), expected \(16,\)"),
        ({"action": np.full(16, np.nan)}, "action contains NaN or inf"),
        ({"qvel": np.r_[np.zeros(15), np.inf]}, "qvel contains NaN or inf"),
        ({"reward": np.nan}, "reward contains NaN"),
        ({"env_state": np.zeros(6)}, "env_state has shape"),
        ({"qpos": "abc"}, "qpos must be numeric"),
        ({"images": {}}, "expected"),
        ({"images": {"cam_a": np.zeros((H, W, 3), np.float32)}}, "float32"),
        ({"images": {"cam_a": np.zeros((H + 1, W, 3), np.uint8)}}, "expected uint8"),
    ],
)
def test_append_validates(tmp_path, change, message):
    w = EpisodeWriter(tmp_path / "episode_0.hdf5", 2, ["cam_a"], H, W, attrs=ATTRS)
    step = {**_step(), **change}
    with pytest.raises(EpisodeWriteError, match=message) as exc_info:
        w.append(**step)
    _assert_one_line(exc_info)
    assert "step 0" in str(exc_info.value)
    w.append(**_step())  # a rejected step does not count
    assert w.num_steps == 1
    w.abort()
    assert _files(tmp_path) == []


def test_too_many_steps_and_bad_arguments(tmp_path):
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS) as w:
        w.append(**_step(cams=()))
        with pytest.raises(EpisodeWriteError, match="already appended"):
            w.append(**_step(cams=()))
    with pytest.raises(EpisodeWriteError, match="compression"):
        EpisodeWriter(tmp_path / "episode_1.hdf5", 1, compression="zstd")
    with pytest.raises(EpisodeWriteError, match="episode_len"):
        EpisodeWriter(tmp_path / "episode_1.hdf5", 0)
    with pytest.raises(EpisodeWriteError, match="invalid camera names"):
        EpisodeWriter(tmp_path / "episode_1.hdf5", 1, ["a/b"], H, W)
    with pytest.raises(EpisodeWriteError, match="duplicate camera names"):
        EpisodeWriter(tmp_path / "episode_1.hdf5", 1, ["a", "a"], H, W)
    with pytest.raises(EpisodeWriteError, match="attribute 'seed'"):
        EpisodeWriter(tmp_path / "episode_1.hdf5", 1, attrs={"seed": "x"})
    assert _files(tmp_path) == ["episode_0.hdf5"]


def test_close_after_abort_fails(tmp_path):
    w = EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS)
    w.abort()
    with pytest.raises(EpisodeWriteError, match="aborted"):
        w.close()
    assert _files(tmp_path) == []


def test_close_is_idempotent_and_append_after_close_fails(tmp_path):
    w = EpisodeWriter(tmp_path / "episode_0.hdf5", 1, attrs=ATTRS)
    w.append(**_step(cams=()))
    assert w.close() == tmp_path / "episode_0.hdf5"
    assert w.close() == tmp_path / "episode_0.hdf5" and w.closed
    with pytest.raises(EpisodeWriteError, match="closed"):
        w.append(**_step(cams=()))


def test_creates_folder_and_set_attrs_at_end(tmp_path):
    path = tmp_path / "a" / "b" / "episode_0.hdf5"
    with EpisodeWriter(path, 1, attrs={"task_name": "t", "seed": 0, "box_pose": [0] * 7}) as w:
        w.append(**_step(cams=()))
        w.set_attrs(success=True, note="extra attribute")
    ep = load_episode(path)
    assert ep.attrs["success"] is True and ep.attrs["note"] == "extra attribute"


def test_temporary_names_are_unique_per_writer(tmp_path):
    """Two writers of one episode name never share a temporary file (two runs on one
    folder used to delete and overwrite each other's)."""
    path = tmp_path / "episode_0.hdf5"
    first = EpisodeWriter(path, 1, attrs=ATTRS)
    second = EpisodeWriter(path, 1, attrs=ATTRS)
    try:
        assert first.temp_path != second.temp_path
        for w in (first, second):
            assert w.temp_path.name.startswith(f".episode_0.hdf5.{os.getpid()}-")
            assert w.temp_path.name.endswith(".tmp")
        first.append(**_step(cams=()))
        first.close()
        second.append(**_step(cams=()))
        with pytest.raises(EpisodeWriteError, match="appeared while writing"):
            second.close()
    finally:
        second.abort()
    assert _files(tmp_path) == ["episode_0.hdf5"]
    assert load_episode(path).num_steps == 1


def test_writer_owned_attributes_cannot_change(tmp_path):
    with pytest.raises(EpisodeWriteError, match="set by the writer"):
        EpisodeWriter(tmp_path / "episode_0.hdf5", 2, attrs={**ATTRS, "episode_len": 3})
    with EpisodeWriter(tmp_path / "episode_0.hdf5", 1, ["cam_a"], H, W, attrs=ATTRS) as w:
        w.set_attrs(camera_names=["cam_a"], dt=0.01)  # same value / not writer-owned: fine
        with pytest.raises(EpisodeWriteError, match="camera_names"):
            w.set_attrs(camera_names=["cam_b"])
        w.append(**_step())
    assert load_episode(tmp_path / "episode_0.hdf5").dt == 0.01


def _write_big(path, num_steps, frame):
    z, pose = np.zeros(16), np.zeros(7)
    with EpisodeWriter(path, num_steps, ["a", "b"], *frame.shape[:2], attrs=ATTRS) as w:
        for _ in range(num_steps):
            w.append(z, z, z, 0.0, pose, {"a": frame, "b": frame})


def test_memory_stays_flat(tmp_path):
    frame = np.full((120, 160, 3), 7, np.uint8)
    _write_big(tmp_path / "episode_0.hdf5", 2, frame)  # warm-up: imports, caches
    tracemalloc.start()
    try:
        _write_big(tmp_path / "episode_1.hdf5", 100, frame)  # 11.5 MB of images
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2_000_000


def test_env_state_width_is_chosen_per_episode(tmp_path):
    """Tasks with two objects (peg insertion) store 14 env_state values per step."""
    path = tmp_path / "episode_0.hdf5"
    with EpisodeWriter(path, episode_len=2, attrs=ATTRS, env_state_dim=14) as w:
        for _ in range(2):
            w.append(np.zeros(16), np.zeros(16), np.zeros(16), 0.0, np.arange(14.0), {})
    ep = load_episode(path)
    assert ep.env_state.shape == (2, 14)
    np.testing.assert_array_equal(ep.env_state[1], np.arange(14.0))
    with pytest.raises(EpisodeWriteError, match=r"env_state has shape \(7,\), expected \(14,\)"):
        with EpisodeWriter(
            tmp_path / "episode_1.hdf5", episode_len=1, attrs=ATTRS, env_state_dim=14
        ) as w:
            w.append(np.zeros(16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7), {})
    assert not (tmp_path / "episode_1.hdf5").exists()
