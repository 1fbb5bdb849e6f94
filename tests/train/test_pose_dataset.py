"""The derived dataset's folder (``train.pose_dataset``): the copy a pose policy trains on
leaves the camera out, everywhere LeRobot would look for it, and keeps the rest.

The whole derivation (episodes, encoder, copy, a LeRobot training run on it) is exercised by
``tests/train/test_train_command.py``'s camera_pose test."""

from __future__ import annotations

import json

import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from trossen_arm_mujoco.train.pose_dataset import _drop_images  # noqa: E402

CAM = "observation.images.cam_high"


def _dataset(root):
    """A LeRobot v3.0 folder's metadata with one camera and two vector features."""
    (root / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
    video = root / "videos" / CAM / "chunk-000"
    video.mkdir(parents=True)
    (video / "file-000.mp4").write_bytes(b"not decoded here")
    info = {
        "fps": 30,
        "features": {
            "observation.state": {"dtype": "float32", "shape": [14]},
            "observation.environment_state": {"dtype": "float32", "shape": [7]},
            CAM: {"dtype": "video", "shape": [60, 80, 3]},
        },
        "trossen_arm_mujoco": {"cam_names": ["cam_high"], "crops": ["cam_high:0,0,48,64"]},
    }
    (root / "meta" / "info.json").write_text(json.dumps(info))
    stats = {k: {"mean": [0.0]} for k in info["features"]}
    (root / "meta" / "stats.json").write_text(json.dumps(stats))
    table = pa.table(
        {
            "episode_index": [0, 1],
            f"videos/{CAM}/chunk_index": [0, 0],
            f"videos/{CAM}/from_timestamp": [0.0, 1.0],
            f"stats/{CAM}/mean": [[0.5], [0.4]],
            "stats/observation.state/mean": [[0.1], [0.2]],
        }
    )
    pq.write_table(table, root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")


def test_the_copy_leaves_the_camera_out_and_keeps_the_rest(tmp_path):
    _dataset(tmp_path)
    assert _drop_images(tmp_path) == [CAM]
    info = json.loads((tmp_path / "meta" / "info.json").read_text())
    assert set(info["features"]) == {"observation.state", "observation.environment_state"}
    assert info["trossen_arm_mujoco"]["cam_names"] == ["cam_high"]  # what a checkpoint sees
    assert set(json.loads((tmp_path / "meta" / "stats.json").read_text())) == set(info["features"])
    columns = pq.read_table(tmp_path / "meta/episodes/chunk-000/file-000.parquet").column_names
    assert columns == ["episode_index", "stats/observation.state/mean"]
    assert not (tmp_path / "videos").exists()


def test_a_dataset_without_a_camera_is_left_as_it_is(tmp_path):
    _dataset(tmp_path)
    _drop_images(tmp_path)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert _drop_images(tmp_path) == []
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
