"""Validated loading: good files, vendor files, and every kind of broken file."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data.reader import (
    EpisodeError,
    episode_path,
    iter_episodes,
    list_episodes,
    load_episode,
    resolve_data_dir,
)
from trossen_arm_mujoco.errors import UserError

VENDOR_CAMS = ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]


def _load_error(path, match):
    with pytest.raises(EpisodeError, match=match) as exc_info:
        load_episode(path)
    assert isinstance(exc_info.value, UserError)
    assert "\n" not in str(exc_info.value)
    return str(exc_info.value)


def _edit(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)


def _replace(f, name, data):
    del f[name]
    f[name] = data


# --- vendor recordings -------------------------------------------------------------------


def test_vendor_episode_with_cameras(vendor_4cams):
    ep = load_episode(vendor_4cams)
    assert ep.is_vendor and ep.num_steps == 5
    for arr in (ep.qpos, ep.qvel, ep.action):
        assert arr.dtype == np.float64 and arr.shape == (5, 16)
    assert ep.reward is None and ep.env_state is None and ep.box_pose is None
    assert ep.camera_names == VENDOR_CAMS
    assert ep.attrs == {"sim": True}
    assert ep.dt == pytest.approx(0.02)
    assert ep.image_shapes["cam_high"] == (480, 640, 3)
    assert ep.images is None
    frames = list(ep.iter_frames("cam_low"))
    assert len(frames) == 5 and frames[0].shape == (480, 640, 3) and frames[0].dtype == np.uint8
    with ep.open_frames() as reader:
        step = reader.step(4)
    assert list(step) == VENDOR_CAMS
    np.testing.assert_array_equal(step["cam_low"], frames[4])
    np.testing.assert_allclose(ep.qpos[0, :3], [0, np.pi / 12, np.pi / 12], atol=1e-6)


def test_vendor_episode_without_images(vendor_no_images):
    ep = load_episode(vendor_no_images)
    assert ep.is_vendor and ep.num_steps == 600 and ep.camera_names == []
    assert not ep.has_images and ep.action.dtype == np.float64
    meta = json.loads(vendor_no_images.with_suffix(".json").read_text())
    assert len(meta["box_xyz_at_spawn"]) == 3


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_schema_1_and_2_files_load_alike(tmp_path, make_episode, dtype):
    """Version 2 files are float32; version 1 files (older recordings) float64."""
    path = tmp_path / "episode_0.hdf5"
    data = make_episode(path, num_steps=3, cams=["cam_high"], compression="gzip")
    if dtype is np.float64:  # rewrite as this package wrote files before version 2
        with h5py.File(path, "r+") as f:
            for name in (
                "observations/qpos",
                "observations/qvel",
                "action",
                "reward",
                "observations/env_state",
            ):
                _replace(f, name, data[name.split("/")[-1]].astype(np.float64))
            f.attrs["schema_version"] = 1
    with h5py.File(path, "r") as f:
        assert f["action"].dtype == dtype
    ep = load_episode(path, load_images=True)
    expected = data["qpos"].astype(dtype)
    assert ep.qpos.dtype == np.float64 and not ep.is_vendor
    np.testing.assert_array_equal(ep.qpos, expected)
    np.testing.assert_array_equal(ep.images["cam_high"], data["images"]["cam_high"])


def test_frame_reader_errors(vendor_4cams):
    ep = load_episode(vendor_4cams)
    with pytest.raises(EpisodeError, match="no camera 'nope'"):
        ep.read_frame("nope", 0)
    with pytest.raises(EpisodeError, match="out of range"):
        ep.read_frame("cam_high", 5)


# --- broken files --------------------------------------------------------------------------


def test_missing_file_and_folder(tmp_path):
    _load_error(tmp_path / "episode_0.hdf5", "episode file not found")
    _load_error(tmp_path, "is not a file")


def test_random_bytes(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    path.write_bytes(os.urandom(4096))
    msg = _load_error(path, "not a readable HDF5 episode file")
    assert str(path) in msg


def test_truncated_file(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=20, height=48, width=64)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    _load_error(path, "not a readable HDF5 episode file")


def test_empty_file(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    path.write_bytes(b"")
    _load_error(path, "not a readable HDF5")


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda f: _replace(f, "observations/qpos", np.zeros((3, 15))), r"shape \(3, 15\)"),
        (lambda f: _replace(f, "action", np.zeros(3)), r"expected \(T, 16\)"),
        (lambda f: _replace(f, "action", np.zeros((3, 16), np.int32)), "dtype int32"),
        (lambda f: _replace(f, "action", np.zeros((2, 16))), "length mismatch"),
        (lambda f: _replace(f, "reward", np.zeros((3, 2))), "/reward has shape"),
        (lambda f: _replace(f, "observations/env_state", np.zeros((3, 6))), "env_state"),
        (lambda f: f["action"].__setitem__((1, 2), np.nan), r"/action contains NaN.*step 1"),
        (lambda f: f["observations/qvel"].__setitem__((2, 0), np.inf), "qvel contains NaN"),
        (lambda f: f.__delitem__("observations/qvel"), "missing dataset /observations/qvel"),
        (lambda f: f.__delitem__("reward"), "missing dataset /reward"),
        (lambda f: f.attrs.__delitem__("seed"), r"missing root attributes \['seed'\]"),
        (lambda f: f.attrs.__setitem__("schema_version", 99), "schema_version 99"),
        (lambda f: f.attrs.__setitem__("episode_len", 7), "episode_len=7"),
        (
            lambda f: _replace(f, "observations/images/cam_a", np.zeros((3, 4, 4, 3), "f4")),
            "dtype float32",
        ),
        (
            lambda f: _replace(f, "observations/images/cam_a", np.zeros((2, 4, 4, 3), "u1")),
            "length mismatch",
        ),
        (
            lambda f: _replace(f, "observations/images/cam_a", np.zeros((3, 4, 4), "u1")),
            r"expected \(T, H, W, 3\)",
        ),
        (
            lambda f: f.__delitem__("observations/images/cam_a"),
            r"camera_names lists \['cam_a'\]",
        ),
    ],
)
def test_invalid_content(tmp_path, make_episode, edit, match):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=3, cams=["cam_a"])
    _edit(path, edit)
    _load_error(path, match)


def test_vendor_file_with_bad_shape_is_rejected(tmp_path, vendor_no_images):
    path = tmp_path / "episode_0.hdf5"
    shutil.copy(vendor_no_images, path)
    _edit(path, lambda f: _replace(f, "observations/qpos", np.zeros((600, 14), "f4")))
    _load_error(path, r"shape \(600, 14\)")


# --- folders -------------------------------------------------------------------------------


def test_list_and_iter_episodes(tmp_path, make_episode):
    for idx in (10, 2, 0):
        make_episode(tmp_path / f"episode_{idx}.hdf5", num_steps=2, cams=[], seed=idx)
    for name in (".episode_3.hdf5.tmp", "episode_01.hdf5", "episode_x.hdf5", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "episode_4.hdf5").mkdir()
    found = list_episodes(tmp_path)
    assert [idx for idx, _ in found] == [0, 2, 10]
    assert found[1][1] == tmp_path / "episode_2.hdf5"
    assert [ep.attrs["seed"] for ep in iter_episodes(tmp_path)] == [0, 2, 10]


def test_list_episodes_missing_folder(tmp_path):
    with pytest.raises(EpisodeError, match="data folder not found"):
        list_episodes(tmp_path / "nope")
    assert list_episodes(tmp_path / "nope", missing_ok=True) == []


def test_episode_path_and_resolve_data_dir(tmp_path):
    assert episode_path(tmp_path, 3) == tmp_path / "episode_3.hdf5"
    with pytest.raises(EpisodeError):
        episode_path(tmp_path, -1)
    assert resolve_data_dir(tmp_path, "sim_transfer_cube") == tmp_path / "sim_transfer_cube"
    assert resolve_data_dir(tmp_path, "/abs/data") == Path("/abs/data")
    assert resolve_data_dir("~/root", "d") == Path.home() / "root" / "d"
    assert resolve_data_dir(tmp_path, "~/d") == Path.home() / "d"
    with pytest.raises(UserError):
        resolve_data_dir(tmp_path, "")
