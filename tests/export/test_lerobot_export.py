"""The LeRobot export without LeRobot: files, columns, metadata, videos (PyAV), errors.

tests/export/test_lerobot_load.py loads the same kind of export with the real
``LeRobotDataset``; this file checks the written files directly so the feature is tested
wherever pyarrow and PyAV are installed.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
av = pytest.importorskip("av")

from trossen_arm_mujoco import cli as main_cli  # noqa: E402
from trossen_arm_mujoco.data.reader import list_episodes, load_episode  # noqa: E402
from trossen_arm_mujoco.data.schema import JOINT_NAMES  # noqa: E402
from trossen_arm_mujoco.export import lerobot_format as fmt  # noqa: E402
from trossen_arm_mujoco.export.lerobot_video import CameraVideo  # noqa: E402
from trossen_arm_mujoco.scripts.export_dataset import cli  # noqa: E402
from trossen_arm_mujoco.tasks import registry  # noqa: E402

CAMS = ["cam_high", "cam_left_wrist"]  # the recorded fixture's cameras, 48x64
H, W = 48, 64
VENDOR = Path(__file__).parents[1] / "fixtures" / "vendor_episode_5steps_4cams.hdf5"


def run(capsys, data_dir: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    rc = cli(["--data_dir", str(data_dir), "--output", str(out), "--repo_id", "me/ds", *extra])
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


def decode(path: Path) -> tuple[np.ndarray, list[float], str, str]:
    """All frames of an mp4 (uint8 (N, H, W, 3)), their timestamps (s), codec, pix_fmt."""
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames, times = [], []
        for frame in container.decode(stream):
            frames.append(frame.to_ndarray(format="rgb24"))
            times.append(float(frame.pts * stream.time_base))
        return np.stack(frames), times, stream.codec_context.name, stream.codec_context.pix_fmt


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return 100.0 if mse == 0 else 10.0 * np.log10(255.0**2 / mse)


def misaligned(decoded: np.ndarray, source: np.ndarray) -> list[tuple[int, int]]:
    """``(t, s)`` where decoded frame ``t`` matches source frame ``s != t`` clearly better
    (squared error below 80 %, about 1 dB): frames in the wrong order or place. Near-equal
    source frames (an arm at rest) differ less than the codec's noise and pass."""
    out = []
    for t, frame in enumerate(decoded.astype(np.float64)):
        errors = np.mean((source.astype(np.float64) - frame) ** 2, axis=(1, 2, 3))
        best = int(np.argmin(errors))
        if best != t and errors[best] < 0.8 * errors[t]:
            out.append((t, best))
    return out


def test_recorded_episodes_default_export(recorded, tmp_path, capsys):
    out = tmp_path / "ds"
    rc, stdout, err = run(capsys, recorded, out)
    assert rc == 0, err
    assert (
        "exported 2 episode(s), 40 frames at 50 fps (cameras: cam_high, cam_left_wrist)" in stdout
    )
    assert "LeRobotDataset('me/ds', root=" in stdout
    assert "export: 100%" in err  # progress bar over episodes
    assert not (tmp_path / ".ds.tmp").exists()
    episodes = [load_episode(p, load_images=True) for _, p in list_episodes(recorded)]

    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 50
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (2, 40, 1)
    assert info["data_path"] == fmt.DATA_PATH and info["video_path"] == fmt.VIDEO_PATH
    assert info["splits"] == {"train": "0:2"}
    feats = info["features"]
    assert list(feats) == [
        "observation.state", "observation.velocity", "action",
        "observation.images.cam_high", "observation.images.cam_left_wrist",
        "next.reward", "next.success",
        "timestamp", "frame_index", "episode_index", "index", "task_index",
    ]  # fmt: skip
    for key in ("observation.state", "observation.velocity", "action"):
        assert feats[key] == {"dtype": "float32", "shape": [16], "names": list(JOINT_NAMES)}
    cam_feat = feats["observation.images.cam_high"]
    assert cam_feat["dtype"] == "video" and cam_feat["shape"] == [H, W, 3]
    assert cam_feat["info"]["video.codec"] == "av1"
    assert cam_feat["info"]["video.pix_fmt"] == "yuv420p"
    assert cam_feat["info"]["video.fps"] == 50

    table = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert table.schema.field("observation.state").type == pa.list_(pa.float32(), 16)
    assert table.schema.field("next.reward").type == pa.float32()
    assert table.schema.field("next.success").type == pa.bool_()
    assert pq.ParquetFile(out / "data/chunk-000/file-000.parquet").num_row_groups == 2
    cols = table.to_pydict()
    assert cols["index"] == list(range(40))
    assert cols["episode_index"] == [0] * 20 + [1] * 20
    assert cols["frame_index"] == list(range(20)) * 2
    assert np.array_equal(np.float32(cols["timestamp"]), np.float32(np.arange(40) % 20 / 50))
    state = np.array(cols["observation.state"], dtype=np.float32)
    action = np.array(cols["action"], dtype=np.float32)
    for i, ep in enumerate(episodes):
        assert np.array_equal(state[20 * i : 20 * (i + 1)], ep.qpos.astype(np.float32))
        assert np.array_equal(action[20 * i : 20 * (i + 1)], ep.action.astype(np.float32))
        reward = np.float32(cols["next.reward"][20 * i : 20 * (i + 1)])
        assert np.array_equal(reward, ep.reward.astype(np.float32))

    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [r["length"] for r in rows] == [20, 20]
    assert [(r["dataset_from_index"], r["dataset_to_index"]) for r in rows] == [(0, 20), (20, 40)]
    task = registry.load("sim_transfer_cube").description
    assert [r["tasks"] for r in rows] == [[task], [task]]
    key = "videos/observation.images.cam_high"
    assert [(r[f"{key}/from_timestamp"], r[f"{key}/to_timestamp"]) for r in rows] == [
        (0.0, 0.4),
        (0.4, 0.8),
    ]
    assert len(rows[0]["stats/observation.state/mean"]) == 16
    assert np.array(rows[0]["stats/observation.images.cam_high/mean"]).shape == (3, 1, 1)

    tasks = pq.read_table(out / "meta/tasks.parquet")
    assert tasks.to_pydict() == {"task_index": [0], "task": [task]}
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["task"]

    stats = json.loads((out / "meta/stats.json").read_text())
    assert set(stats) == set(feats)
    assert stats["observation.state"]["count"] == [40]
    assert np.allclose(stats["observation.state"]["mean"], state.astype(np.float64).mean(0))
    assert np.allclose(stats["observation.state"]["std"], state.astype(np.float64).std(0))
    assert np.array(stats["observation.images.cam_left_wrist"]["mean"]).shape == (3, 1, 1)

    for cam in CAMS:
        frames, times, codec, pix_fmt = decode(
            out / f"videos/observation.images.{cam}/chunk-000/file-000.mp4"
        )
        assert (codec, pix_fmt) == ("libdav1d", "yuv420p") or codec in ("av1", "libaom-av1")
        assert frames.shape == (40, H, W, 3)
        assert np.allclose(times, np.arange(40) / 50)
        source = np.concatenate([ep.images[cam] for ep in episodes])
        # yuv420p halves the colour resolution: tiny 48x64 renders stay near 33 dB at best
        # (>= 36 dB at 480x640); frame order is checked on clearer motion below
        assert min(psnr(a, b) for a, b in zip(frames, source)) > 28


def test_float32_and_compressed_episodes_and_rolling_files(
    tmp_path, capsys, monkeypatch, make_episode, make_float32
):
    data = tmp_path / "eps"
    make_episode(data / "episode_0.hdf5", 12, ["top"], seed=0)
    make_episode(data / "episode_2.hdf5", 9, ["top"], seed=1, compression="gzip")
    make_episode(data / "episode_3.hdf5", 10, ["top"], seed=2, compression="lzf")
    make_float32(data / "episode_2.hdf5")
    make_float32(data / "episode_3.hdf5")
    episodes = [load_episode(p, load_images=True) for _, p in list_episodes(data)]
    monkeypatch.setattr(fmt, "DATA_FILES_SIZE_MB", 1e-6)  # every episode starts a new file
    monkeypatch.setattr(fmt, "VIDEO_FILES_SIZE_MB", 1e-6)
    monkeypatch.setattr(fmt, "CHUNKS_SIZE", 2)  # and two files fill a chunk
    out = tmp_path / "ds"
    rc, _, err = run(capsys, data, out, "--vcodec", "h264", "--pix_fmt", "yuv444p", "--crf", "12")
    assert rc == 0, err

    info = json.loads((out / "meta/info.json").read_text())
    assert info["total_frames"] == 31 and info["chunks_size"] == 2
    assert info["features"]["observation.images.top"]["info"]["video.codec"] == "h264"
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    where = [(r["data/chunk_index"], r["data/file_index"]) for r in rows]
    assert where == [(0, 0), (0, 1), (1, 0)]
    vkey = "videos/observation.images.top"
    assert [(r[f"{vkey}/chunk_index"], r[f"{vkey}/file_index"]) for r in rows] == where
    assert [r[f"{vkey}/from_timestamp"] for r in rows] == [0.0, 0.0, 0.0]
    assert [r[f"{vkey}/to_timestamp"] for r in rows] == [12 / 50, 9 / 50, 10 / 50]
    assert [r["tasks"] for r in rows] == [[registry.load("sim_insertion").description]] * 3

    for i, (ep, (chunk, file)) in enumerate(zip(episodes, where)):
        table = pq.read_table(out / fmt.FileIndex(chunk, file).path(fmt.DATA_PATH)).to_pydict()
        assert table["episode_index"] == [i] * ep.num_steps
        assert np.array_equal(np.float32(table["observation.velocity"]), np.float32(ep.qvel))
        assert table["next.success"] == (ep.reward >= 4).tolist()
        assert any(table["next.success"]) and not all(table["next.success"])
        video = out / fmt.FileIndex(chunk, file).path(
            fmt.VIDEO_PATH, video_key="observation.images.top"
        )
        frames, _, codec, pix_fmt = decode(video)
        assert (codec, pix_fmt) == ("h264", "yuv444p")
        assert frames.shape[0] == ep.num_steps
        assert min(psnr(a, b) for a, b in zip(frames, ep.images["top"])) >= 35
        assert misaligned(frames, ep.images["top"]) == []


def test_vendor_recording_needs_a_task_and_has_no_reward(tmp_path, capsys):
    data = tmp_path / "vendor"
    data.mkdir()
    shutil.copy(VENDOR, data / "episode_0.hdf5")
    rc, _, err = run(capsys, data, tmp_path / "ds")
    assert rc == 2
    assert err.count("\n") == 1 and "has no task_name attribute" in err and "--task" in err
    rc, _, err = run(capsys, data, tmp_path / "ds", "--task", "hand over the cube")
    assert rc == 0, err
    info = json.loads((tmp_path / "ds/meta/info.json").read_text())
    assert "next.reward" not in info["features"] and "next.success" not in info["features"]
    assert info["total_frames"] == 5
    assert [k for k in info["features"] if k.startswith("observation.images.")] == [
        f"observation.images.{cam}" for cam in load_episode(VENDOR).camera_names
    ]
    tasks = pq.read_table(tmp_path / "ds/meta/tasks.parquet").to_pydict()
    assert tasks["task"] == ["hand over the cube"]


def _dataset_in(folder: Path, mk) -> None:
    mk(folder / "episode_0.hdf5", 3, [], seed=0)


@pytest.mark.parametrize(
    ("setup", "extra", "needle"),
    [
        (lambda d, o, mk: None, [], "data folder not found"),
        (lambda d, o, mk: d.mkdir(), [], "no episode_<k>.hdf5 files"),
        (
            lambda d, o, mk: (d.mkdir(), (d / "episode_0.hdf5").write_bytes(b"not hdf5")),
            [],
            "not a readable HDF5 episode file",
        ),
        (
            lambda d, o, mk: (_dataset_in(d, mk), o.mkdir(), (o / "notes.txt").write_text("x")),
            [],
            "is not empty; choose another --output or pass --overwrite",
        ),
        (
            lambda d, o, mk: (_dataset_in(d, mk), o.mkdir(), (o / "notes.txt").write_text("x")),
            ["--overwrite"],
            "holds no LeRobot dataset",
        ),
        (
            lambda d, o, mk: _dataset_in(d, mk),
            ["--pix_fmt", "yuv444p"],
            "libsvtav1 encodes yuv420p only",
        ),
        (
            lambda d, o, mk: _dataset_in(d, mk),
            ["--repo_id", "no-slash"],
            "--repo_id must look like",
        ),
        (
            lambda d, o, mk: _dataset_in(d, mk),
            ["--vcodec", "h264", "--crf", "60"],
            "--crf for h264 must be in 0..51",
        ),
        (lambda d, o, mk: _dataset_in(d, mk), ["--task", "  "], "--task must not be empty"),
        (
            lambda d, o, mk: (
                mk(d / "episode_0.hdf5", 3, ["a"], seed=0),
                mk(d / "episode_1.hdf5", 3, ["b"], seed=0),
            ),
            [],
            "every episode of a dataset needs the same cameras",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, make_episode, setup, extra, needle):
    data, out = tmp_path / "eps", tmp_path / "ds"
    setup(data, out, make_episode)
    rc, stdout, err = run(capsys, data, out, *extra)
    assert rc == 2
    assert err.startswith("error: ") and err.count("\n") == 1 and needle in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("module", ["pyarrow", "av"])
def test_missing_dependency_names_the_extra(tmp_path, capsys, monkeypatch, make_episode, module):
    make_episode(tmp_path / "eps" / "episode_0.hdf5", 3, ["top"], seed=0)
    for name in list(sys.modules):
        if name == module or name.startswith(module + "."):
            monkeypatch.setitem(sys.modules, name, None)  # import raises ImportError
    rc, _, err = run(capsys, tmp_path / "eps", tmp_path / "ds")
    assert rc == 2 and err.count("\n") == 1
    assert f"needs the '{module}' package" in err
    assert 'pip install "trossen_arm_mujoco[lerobot]"' in err
    assert not (tmp_path / "ds").exists()


def test_overwrite_replaces_a_dataset_only_when_the_new_one_is_complete(
    tmp_path, capsys, monkeypatch, make_episode
):
    data, out = tmp_path / "eps", tmp_path / "ds"
    make_episode(data / "episode_0.hdf5", 4, ["top"], seed=0)
    assert run(capsys, data, out)[0] == 0
    make_episode(data / "episode_1.hdf5", 6, ["top"], seed=1)

    def interrupted(self, frames):
        raise KeyboardInterrupt

    monkeypatch.setattr(CameraVideo, "write", interrupted)
    rc, _, err = run(capsys, data, out, "--overwrite")
    assert rc == 130 and "interrupted" in err
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 4  # old one kept
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]  # no temp folder left

    monkeypatch.undo()
    assert run(capsys, data, out, "--overwrite")[0] == 0
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 10


def test_trossen_mujoco_export_dispatch(tmp_path, capsys, make_episode):
    make_episode(tmp_path / "eps" / "episode_0.hdf5", 3, [], seed=0)
    rc = main_cli.main(
        ["export", "--format", "lerobot", "--root_dir", str(tmp_path), "--data_dir", "eps",
         "--output", str(tmp_path / "ds"), "--repo_id", "me/ds"]
    )  # fmt: skip
    assert rc == 0, capsys.readouterr().err
    info = json.loads((tmp_path / "ds/meta/info.json").read_text())
    assert info["video_path"] is None and info["total_frames"] == 3
