"""The episode file layout matches the documented (ACT-style) layout."""

from __future__ import annotations

import fnmatch

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data.schema import (
    ATTR_KINDS,
    EPISODE_FILE_RE,
    SCHEMA,
    SCHEMA_VERSION,
    SCHEMAS,
    encode_attr,
    episode_file_name,
    temp_file_name,
)

# The documented layout, spelled out independently of the schema object.
DOCUMENTED_ARRAYS = {
    "action": ((16,), np.float32),
    "reward": ((), np.float32),
    "observations/qpos": ((16,), np.float32),
    "observations/qvel": ((16,), np.float32),
    "observations/env_state": ((7,), np.float32),
}
DOCUMENTED_ATTRS = {
    "sim",
    "task_name",
    "seed",
    "success",
    "episode_len",
    "dt",
    "camera_names",
    "package_version",
    "mujoco_version",
    "schema_version",
}
#: Checked when present, not required (written for tasks with the cube).
OPTIONAL_CHECKED_ATTRS = {"box_pose"}


def test_schema_object_matches_documented_layout():
    assert SCHEMA.version == SCHEMA_VERSION == 2
    assert SCHEMAS[2] is SCHEMA
    # version 1 (older files of this package): the same layout in float64
    assert {s.path: (s.width, s.dtype) for s in SCHEMAS[1].arrays} == {
        path: (width, np.float64) for path, (width, _) in DOCUMENTED_ARRAYS.items()
    }
    assert SCHEMAS[1].attrs == SCHEMA.attrs
    assert {spec.path: (spec.width, spec.dtype) for spec in SCHEMA.arrays} == DOCUMENTED_ARRAYS
    assert set(SCHEMA.attrs) == DOCUMENTED_ATTRS
    assert set(ATTR_KINDS) == DOCUMENTED_ATTRS | OPTIONAL_CHECKED_ATTRS
    assert SCHEMA.image_path("cam_high") == "observations/images/cam_high"
    assert SCHEMA.image_dtype == np.uint8
    assert SCHEMA.image_chunks(480, 640) == (1, 480, 640, 3)
    assert {spec.path for spec in SCHEMA.arrays if spec.vendor} == {
        "action",
        "observations/qpos",
        "observations/qvel",
    }


def test_written_file_has_documented_layout(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    cams = ["cam_high", "cam_low"]
    make_episode(path, num_steps=3, cams=cams, height=24, width=32)
    with h5py.File(path, "r") as f:
        found = {}
        f.visititems(lambda name, node: found.setdefault(name, node) and None)
        datasets = {n: f[n] for n, node in found.items() if isinstance(node, h5py.Dataset)}
        expected = set(DOCUMENTED_ARRAYS) | {f"observations/images/{c}" for c in cams}
        assert set(datasets) == expected
        for name, (width, dtype) in DOCUMENTED_ARRAYS.items():
            assert f[name].shape == (3, *width), name
            assert f[name].dtype == dtype, name
        for cam in cams:
            images = f[f"observations/images/{cam}"]
            assert images.shape == (3, 24, 32, 3)
            assert images.dtype == np.uint8
            assert images.chunks == (1, 24, 32, 3)
        attrs = dict(f.attrs)
    assert set(attrs) == DOCUMENTED_ATTRS | OPTIONAL_CHECKED_ATTRS  # the fixture writes box_pose
    assert isinstance(attrs["sim"], np.bool_) and attrs["sim"]
    assert attrs["schema_version"] == 2
    assert attrs["episode_len"] == 3
    assert attrs["task_name"] == "sim_transfer_cube"
    assert isinstance(attrs["success"], np.bool_) and attrs["success"]
    assert attrs["dt"] == pytest.approx(0.02)
    assert [c.decode() if isinstance(c, bytes) else c for c in attrs["camera_names"]] == cams
    assert np.asarray(attrs["box_pose"]).shape == (7,)
    assert isinstance(attrs["mujoco_version"], str) and attrs["mujoco_version"]
    assert isinstance(attrs["package_version"], str) and attrs["package_version"]


def test_no_cameras_stores_empty_camera_list(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=2, cams=[])
    with h5py.File(path, "r") as f:
        assert list(f.attrs["camera_names"]) == []
        assert len(f.get("observations/images", {})) == 0


def test_file_names_and_temp_names():
    assert episode_file_name(3) == "episode_3.hdf5"
    assert EPISODE_FILE_RE.match("episode_12.hdf5").group(1) == "12"
    for name in ["episode_01.hdf5", "episode_x.hdf5", "episode_3.hdf5.tmp", "foo.hdf5"]:
        assert EPISODE_FILE_RE.match(name) is None, name
    tmp = temp_file_name("episode_3.hdf5")
    assert tmp == ".episode_3.hdf5.tmp"
    assert not fnmatch.fnmatch(tmp, "episode_*.hdf5")
    assert EPISODE_FILE_RE.match(tmp) is None


@pytest.mark.parametrize(
    "name, value",
    [
        ("seed", 1.5),
        ("seed", True),
        ("success", 1),
        ("task_name", 3),
        ("dt", -0.1),
        ("box_pose", [0.0, 1.0]),
        ("box_pose", [np.nan] * 7),
        ("camera_names", [1, 2]),
    ],
)
def test_encode_attr_rejects_wrong_kinds(name, value):
    with pytest.raises(ValueError, match=f"attribute '{name}' must be"):
        encode_attr(name, value)


def test_encode_attr_converts():
    assert encode_attr("seed", np.int32(4)) == 4
    assert encode_attr("success", False) == np.False_
    assert encode_attr("box_pose", (0, 0, 0, 1, 0, 0, 0)).dtype == np.float64
    assert encode_attr("my_extra", ["a", "b"]).shape == (2,)
