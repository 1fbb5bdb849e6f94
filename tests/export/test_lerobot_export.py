"""The LeRobot export without LeRobot: files, columns, metadata, videos (PyAV), errors.

tests/export/test_lerobot_load.py loads the same kind of export with the real
``LeRobotDataset``; this file checks the written files directly so the feature is tested
wherever pyarrow and PyAV are installed. Also: one-line errors for bad episodes and for
output folders that refuse the writes, and Ctrl-C / SIGTERM in a real process.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from fractions import Fraction
from pathlib import Path

import h5py
import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
av = pytest.importorskip("av")

from trossen_arm_mujoco import cli as main_cli  # noqa: E402
from trossen_arm_mujoco.collect.pipeline import ACTION_SPEED_LIMITS  # noqa: E402
from trossen_arm_mujoco.constants import START_ARM_POSE  # noqa: E402
from trossen_arm_mujoco.data.reader import list_episodes, load_episode  # noqa: E402
from trossen_arm_mujoco.data.schema import JOINT_NAMES  # noqa: E402
from trossen_arm_mujoco.data.writer import EpisodeWriter  # noqa: E402
from trossen_arm_mujoco.export import VideoSettings, export_lerobot  # noqa: E402
from trossen_arm_mujoco.export import lerobot_format as fmt  # noqa: E402
from trossen_arm_mujoco.export.lerobot import controller_actions, frame_values  # noqa: E402
from trossen_arm_mujoco.export.lerobot_plan import frame_map  # noqa: E402
from trossen_arm_mujoco.export.lerobot_video import CameraVideo  # noqa: E402
from trossen_arm_mujoco.fileio import folder_lock  # noqa: E402
from trossen_arm_mujoco.images import psnr  # noqa: E402
from trossen_arm_mujoco.scripts.export_dataset import cli  # noqa: E402
from trossen_arm_mujoco.tasks import registry  # noqa: E402

#: Names, order and units of Trossen's LeRobot plugin for the kit (bi_widowxai_follower_robot):
#: rad for the joints, m for the carriage (the gripper); written down as facts.
KIT14_NAMES = [
    *(f"left_joint_{i}.pos" for i in range(6)),
    "left_left_carriage_joint.pos",
    *(f"right_joint_{i}.pos" for i in range(6)),
    "right_left_carriage_joint.pos",
]
#: Where each of those comes from in the files' 16 values (the carriage: left_carriage_joint).
KIT14_FROM_16 = [0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 15]
BOX_NAMES = ["box_x", "box_y", "box_z", "box_qw", "box_qx", "box_qy", "box_qz"]
CAMS = ["cam_high", "cam_left_wrist"]  # the recorded fixture's cameras, 48x64
H, W = 48, 64
VENDOR = Path(__file__).parents[1] / "fixtures" / "vendor_episode_5steps_4cams.hdf5"
#: Joint velocities are named after the joints: "left_joint_0.vel" ...
KIT14_VEL_NAMES = [n.replace(".pos", ".vel") for n in KIT14_NAMES]


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


def test_recorded_episodes_sim_features_export(recorded, tmp_path, capsys):
    """At the recording rate with the sim's features: every value is the file's."""
    out = tmp_path / "ds"
    rc, stdout, err = run(capsys, recorded, out, "--fps", "50", "--sim_features")
    assert rc == 0, err
    assert (
        "exported 2 episode(s), 40 frames at 50 fps, with the sim's features (cameras: "
        "cam_high, cam_left_wrist), layout kit14 (robot_type bi_widowxai_follower_robot)" in stdout
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
        "action",
        "observation.state",
        "observation.images.cam_high",
        "observation.images.cam_left_wrist",
        "observation.velocity",
        "observation.environment_state",
        "next.reward",
        "next.success",
        "timestamp",
        "frame_index",
        "episode_index",
        "index",
        "task_index",
    ]
    for key in ("observation.state", "observation.velocity", "action"):
        names = KIT14_NAMES if key != "observation.velocity" else KIT14_VEL_NAMES
        assert feats[key] == {"dtype": "float32", "shape": [14], "names": names}
    assert feats["observation.environment_state"] == {
        "dtype": "float32",
        "shape": [7],
        "names": BOX_NAMES,
    }
    assert info["robot_type"] == fmt.ROBOT_TYPE
    cam_feat = feats["observation.images.cam_high"]
    assert cam_feat["dtype"] == "video" and cam_feat["shape"] == [H, W, 3]
    assert cam_feat["info"]["video.codec"] == "av1"
    assert cam_feat["info"]["video.pix_fmt"] == "yuv420p"
    assert cam_feat["info"]["video.fps"] == 50

    table = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert table.schema.field("observation.state").type == pa.list_(pa.float32(), 14)
    assert table.schema.field("observation.environment_state").type == pa.list_(pa.float32(), 7)
    assert table.schema.field("next.reward").type == pa.float32()
    assert table.schema.field("next.success").type == pa.bool_()
    assert pq.ParquetFile(out / "data/chunk-000/file-000.parquet").num_row_groups == 2
    cols = table.to_pydict()
    assert cols["index"] == list(range(40))
    assert cols["episode_index"] == [0] * 20 + [1] * 20
    assert cols["frame_index"] == list(range(20)) * 2
    assert np.array_equal(np.float32(cols["timestamp"]), np.float32(np.arange(40) % 20 / 50))
    state = np.array(cols["observation.state"], dtype=np.float32)
    velocity = np.array(cols["observation.velocity"], dtype=np.float32)
    action = np.array(cols["action"], dtype=np.float32)
    env_state = np.array(cols["observation.environment_state"], dtype=np.float32)
    for i, ep in enumerate(episodes):  # at the recording rate: the file's values, bit for bit
        part = slice(20 * i, 20 * (i + 1))
        assert np.array_equal(state[part], ep.qpos[:, KIT14_FROM_16].astype(np.float32))
        assert np.array_equal(velocity[part], ep.qvel[:, KIT14_FROM_16].astype(np.float32))
        assert np.array_equal(
            action[part], controller_actions(ep.action)[:, KIT14_FROM_16].astype(np.float32)
        )
        assert np.array_equal(env_state[part], ep.env_state.astype(np.float32))
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
    assert len(rows[0]["stats/observation.state/mean"]) == 14
    assert len(rows[0]["stats/observation.environment_state/mean"]) == 7
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
    rc, _, err = run(
        capsys,
        data,
        out,
        "--fps",
        "50",
        "--sim_features",
        "--vcodec",
        "h264",
        "--pix_fmt",
        "yuv444p",
        "--crf",
        "12",
    )
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
        velocity = np.float32(ep.qvel[:, KIT14_FROM_16])
        assert np.array_equal(np.float32(table["observation.velocity"]), velocity)
        assert np.array_equal(np.float32(table["observation.environment_state"]), ep.env_state)
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
    rc, _, err = run(
        capsys,
        data,
        tmp_path / "ds",
        "--task",
        "hand over the cube",
        "--fps",
        "50",
        "--sim_features",
    )
    assert rc == 0, err
    info = json.loads((tmp_path / "ds/meta/info.json").read_text())
    assert "next.reward" not in info["features"] and "next.success" not in info["features"]
    assert "observation.environment_state" not in info["features"]  # vendor files have none
    assert info["features"]["action"]["names"] == KIT14_NAMES
    assert info["features"]["observation.state"]["names"] == KIT14_NAMES
    assert info["features"]["observation.velocity"]["names"] == KIT14_VEL_NAMES
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
        (lambda d, o, mk: _dataset_in(d, mk), ["--fps", "60"], "above the recording rate (50"),
        (lambda d, o, mk: _dataset_in(d, mk), ["--fps", "29.97"], "must be a whole number"),
        (lambda d, o, mk: _dataset_in(d, mk), ["--fps", "thirty"], "must be a whole number"),
        (lambda d, o, mk: _dataset_in(d, mk), ["--fps", "0"], "--fps must be at least 1"),
        (lambda d, o, mk: _dataset_in(d, mk), ["--fps=-30"], "--fps must be at least 1"),
        (
            lambda d, o, mk: _dataset_in(d, mk),  # 3 steps at 50 fps: no whole frame at 10
            ["--fps", "10"],
            "has 3 step(s), too short for --fps 10 (needs at least 5",
        ),
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
    assert 'pip install ".[lerobot]" in the trossen_arm_mujoco checkout' in err
    assert not (tmp_path / "ds").exists()


def test_overwrite_replaces_a_dataset_only_when_the_new_one_is_complete(
    tmp_path, capsys, monkeypatch, make_episode
):
    data, out = tmp_path / "eps", tmp_path / "ds"
    make_episode(data / "episode_0.hdf5", 4, ["top"], seed=0)
    assert run(capsys, data, out, "--fps", "50")[0] == 0
    make_episode(data / "episode_1.hdf5", 6, ["top"], seed=1)

    def interrupted(self, frames):
        raise KeyboardInterrupt

    monkeypatch.setattr(CameraVideo, "write", interrupted)
    rc, _, err = run(capsys, data, out, "--overwrite", "--fps", "50")
    assert rc == 130 and "interrupted" in err
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 4  # old one kept
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]  # no temp folder left

    monkeypatch.undo()
    assert run(capsys, data, out, "--overwrite", "--fps", "50")[0] == 0
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 10


def test_trossen_mujoco_export_dispatch(tmp_path, capsys, make_episode):
    make_episode(tmp_path / "eps" / "episode_0.hdf5", 3, [], seed=0)
    rc = main_cli.main(
        [
            "export",
            "--format",
            "lerobot",
            "--root_dir",
            str(tmp_path),
            "--data_dir",
            "eps",
            "--output",
            str(tmp_path / "ds"),
            "--repo_id",
            "me/ds",
        ]
    )
    assert rc == 0, capsys.readouterr().err
    info = json.loads((tmp_path / "ds/meta/info.json").read_text())
    assert info["video_path"] is None and info["total_frames"] == 1  # floor(3 * 30 / 50)
    assert info["fps"] == 30 and info["robot_type"] == "bi_widowxai_follower_robot"


def test_vendor16_layout_keeps_the_files_16_values(recorded, tmp_path, capsys):
    out = tmp_path / "ds"
    rc, stdout, err = run(
        capsys, recorded, out, "--layout", "vendor16", "--fps", "50", "--sim_features"
    )
    assert rc == 0, err
    assert "layout vendor16 (robot_type trossen_ai_stationary)" in stdout
    info = json.loads((out / "meta/info.json").read_text())
    for key in ("observation.state", "observation.velocity", "action"):
        assert info["features"][key] == {
            "dtype": "float32",
            "shape": [16],
            "names": list(JOINT_NAMES),
        }
    assert info["features"]["observation.environment_state"]["names"] == BOX_NAMES
    cols = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    episodes = [load_episode(p) for _, p in list_episodes(recorded)]
    qpos = np.concatenate([ep.qpos for ep in episodes]).astype(np.float32)
    action = np.concatenate([controller_actions(ep.action) for ep in episodes]).astype(np.float32)
    assert np.array_equal(np.array(cols["observation.state"], dtype=np.float32), qpos)
    assert np.array_equal(np.array(cols["action"], dtype=np.float32), action)


def test_environment_state_names_without_object_names(tmp_path, make_episode):
    # written episodes have two objects (14 values) and no object_names attribute
    make_episode(tmp_path / "eps" / "episode_0.hdf5", 4, [], seed=0)
    export_lerobot(tmp_path / "eps", tmp_path / "ds", "me/ds", progress=False, sim_features=True)
    feature = json.loads((tmp_path / "ds/meta/info.json").read_text())["features"][
        "observation.environment_state"
    ]
    parts = ["x", "y", "z", "qw", "qx", "qy", "qz"]
    assert feature["shape"] == [14]
    assert feature["names"] == [f"obj{i}_{p}" for i in range(2) for p in parts]


# -- resampling (--fps) ---------------------------------------------------------------------

#: A 10-step episode at 50 fps written at 30 fps has floor(10 * 30 / 50) = 6 frames. Frame k
#: is at t_k = k / 30 s, source index 5k/3; its action is the source's at index 5(k+1)/3 - 1,
#: its reward that of step ceil(5(k+1)/3) - 1. Worked out by hand:
#: state at 0, 1 2/3, 3 1/3, 5, 6 2/3, 8 1/3 -> (index, fraction):
HAND_OBS = [(0, 0.0), (1, 2 / 3), (3, 1 / 3), (5, 0.0), (6, 2 / 3), (8, 1 / 3)]
#: action at 2/3, 2 1/3, 4, 5 2/3, 7 1/3, 9:
HAND_ACTION = [(0, 2 / 3), (2, 1 / 3), (4, 0.0), (5, 2 / 3), (7, 1 / 3), (9, 0.0)]
#: images: the source frame nearest 0, 1.67, 3.33, 5, 6.67, 8.33:
HAND_IMAGES = [0, 2, 3, 5, 7, 8]
#: reward: the step whose period (j/50, (j+1)/50] holds the frame's end (k+1)/30:
HAND_REWARD = [1, 3, 4, 6, 8, 9]
FLIPPED_STEP = 4  # the peg's quaternion is stored with the other sign at this step


def _rotation(axis: int, angle: float) -> np.ndarray:
    q = np.zeros(4)
    q[0], q[1 + axis] = np.cos(angle / 2), np.sin(angle / 2)
    return q


def write_synthetic(path: Path, steps: int = 10) -> None:
    """A hand-checkable episode: ramps and parabolas, a peg turning about z (one step stored
    with the quaternion's other sign), a socket turning about x, reward = step index, and
    frames with a square moving 3 px a step."""
    yy, xx = np.mgrid[0:H, 0:W]
    with EpisodeWriter(
        path,
        steps,
        ["top"],
        H,
        W,
        compression="none",
        env_state_dim=14,
        attrs={"task_name": "sim_insertion", "seed": 0, "object_names": ["peg", "socket"]},
    ) as writer:
        for t in range(steps):
            qpos = 0.3 * t / 50 + 0.01 * t**2 * np.arange(16) / 16
            qpos[0] = 0.3 * t / 50  # a ramp: 0.3 rad/s
            qvel = -0.02 * t**2 + np.arange(16)
            action = 0.002 * (t + 1) ** 2 + np.arange(16) / 10
            action[0] = 0.5 * (t + 1) / 50  # the target for the end of step t, 0.5 rad/s
            peg_q = _rotation(2, 0.1 * t) * (-1.0 if t == FLIPPED_STEP else 1.0)
            peg = np.concatenate([[0.1 + 0.01 * t, -0.2, 0.05 + 0.002 * t], peg_q])
            socket = np.concatenate([[0.2, 0.3, 0.0], _rotation(0, 0.05 * t)])
            image = np.stack([40 + (150 * (xx + yy) // (H + W)).astype(np.uint8)] * 3, -1)
            image[H // 3 : H // 3 + 12, 3 * t : 3 * t + 12] = (230, 30, 30)
            writer.append(
                qpos,
                qvel,
                action,
                float(t),
                np.concatenate([peg, socket]),
                {"top": image.astype(np.uint8)},
            )
        writer.set_attrs(success=True)


def _hand(values: np.ndarray, pairs: list[tuple[int, float]]) -> np.ndarray:
    return np.array(
        [(1 - f) * values[j] + f * values[min(j + 1, len(values) - 1)] for j, f in pairs]
    )


def test_fps_30_resampling_against_a_hand_computation(tmp_path, capsys):
    data, out = tmp_path / "eps", tmp_path / "ds"
    write_synthetic(data / "episode_0.hdf5")
    ep = load_episode(data / "episode_0.hdf5", load_images=True)
    rc, stdout, err = run(
        capsys,
        data,
        out,
        "--fps",
        "30",
        "--sim_features",
        "--vcodec",
        "h264",
        "--pix_fmt",
        "yuv444p",
        "--crf",
        "12",
    )
    assert rc == 0, err
    assert "6 frames at 30 fps (resampled from 50 fps)" in stdout
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == 30 and info["total_frames"] == 6
    assert info["features"]["observation.images.top"]["info"]["video.fps"] == 30
    parts = ["x", "y", "z", "qw", "qx", "qy", "qz"]
    names = [f"{obj}_{p}" for obj in ("peg", "socket") for p in parts]
    assert info["features"]["observation.environment_state"]["names"] == names
    cols = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    assert cols["frame_index"] == list(range(6))
    assert np.array_equal(np.float32(cols["timestamp"]), np.float32(np.arange(6) / 30))

    state = np.array(cols["observation.state"])
    velocity = np.array(cols["observation.velocity"])
    action = np.array(cols["action"])
    env = np.array(cols["observation.environment_state"])
    tight = {"rtol": 1e-6, "atol": 1e-7}  # float32 rounding of the written values
    np.testing.assert_allclose(state, _hand(ep.qpos[:, KIT14_FROM_16], HAND_OBS), **tight)
    np.testing.assert_allclose(velocity, _hand(ep.qvel[:, KIT14_FROM_16], HAND_OBS), **tight)
    np.testing.assert_allclose(
        action, _hand(controller_actions(ep.action)[:, KIT14_FROM_16], HAND_ACTION), **tight
    )
    # the ramps: state at t_k = k/30, action = the target for t_{k+1} = (k+1)/30
    np.testing.assert_allclose(state[:, 0], 0.3 * np.arange(6) / 30, **tight)
    np.testing.assert_allclose(action[:, 0], 0.5 * np.arange(1, 7) / 30, **tight)
    assert cols["next.reward"] == HAND_REWARD
    assert cols["next.success"] == [r >= 4 for r in HAND_REWARD]

    # object positions interpolate linearly; quaternions the shorter way, renormalised
    poses = env.reshape(6, 2, 7)
    times = np.array([j + f for j, f in HAND_OBS])  # source index of each frame
    np.testing.assert_allclose(poses[:, 0, 0], 0.1 + 0.01 * times, **tight)
    np.testing.assert_allclose(poses[:, 0, 2], 0.05 + 0.002 * times, **tight)
    np.testing.assert_allclose(np.linalg.norm(poses[..., 3:], axis=-1), 1.0, atol=1e-6)
    for k, (j, f) in enumerate(HAND_OBS):
        peg = _rotation(2, 0.1 * (j + f))  # up to sign, within nlerp's error
        sign = np.sign(ep.env_state[j, 3])
        np.testing.assert_allclose(poses[k, 0, 3:], sign * peg, atol=2e-4)
        np.testing.assert_allclose(poses[k, 1, 3:], _rotation(0, 0.05 * (j + f)), atol=2e-4)
        if f == 0:  # source rows keep their values exactly
            np.testing.assert_array_equal(env[k], ep.env_state[j].astype(np.float32))
    assert HAND_OBS[2][0] + 1 == FLIPPED_STEP  # frame 2 interpolates across the sign flip

    frames, times_s, _, _ = decode(out / "videos/observation.images.top/chunk-000/file-000.mp4")
    assert np.allclose(times_s, np.arange(6) / 30)
    source = ep.images["top"].astype(np.float64)
    nearest = [int(np.argmin(np.mean((source - f) ** 2, axis=(1, 2, 3)))) for f in frames]
    assert nearest == HAND_IMAGES
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert rows[0]["length"] == 6
    assert rows[0]["videos/observation.images.top/to_timestamp"] == pytest.approx(6 / 30)


def test_fps_30_recorded_episodes_lengths_and_speed_limits(recorded, tmp_path, capsys):
    out = tmp_path / "ds"
    rc, stdout, err = run(capsys, recorded, out, "--fps", "30")
    assert rc == 0, err
    assert "24 frames at 30 fps (resampled from 50 fps)" in stdout  # 2 x floor(20 * 30 / 50)
    info = json.loads((out / "meta/info.json").read_text())
    assert (info["fps"], info["total_frames"], info["robot_type"]) == (30, 24, fmt.ROBOT_TYPE)
    cols = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    assert cols["frame_index"] == list(range(12)) * 2
    assert np.array_equal(np.float32(cols["timestamp"]), np.float32(np.arange(24) % 12 / 30))
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [r["length"] for r in rows] == [12, 12]
    for cam in CAMS:
        frames, times, _, _ = decode(
            out / f"videos/observation.images.{cam}/chunk-000/file-000.mp4"
        )
        assert frames.shape[0] == 24 and np.allclose(times, np.arange(24) / 30)
    action = np.array(cols["action"], dtype=np.float64)
    for ep_actions in (action[:12], action[12:]):
        _assert_within_speed_limits(ep_actions, 30)


def _assert_within_speed_limits(actions: np.ndarray, fps: int) -> float:
    """Every value of a kit14 action trajectory moves at most its real speed limit per
    frame (float32 rounding aside); returns the largest fraction of a limit used."""
    limits = ACTION_SPEED_LIMITS[KIT14_FROM_16]
    use = np.abs(np.diff(actions, axis=0)) * fps / limits
    assert use.max(initial=0.0) <= 1 + 1e-5, use.max()
    return float(use.max(initial=0.0))


def test_resampled_action_keeps_the_real_speed_limits(tmp_path):
    """A source action moving at the speed limits (runs of steps at +-limit / 50) resampled
    to 30 fps still moves at most the limits, and reaches them."""
    rng = np.random.default_rng(0)
    steps = 60
    signs = np.repeat(rng.choice([-1.0, 1.0], size=(steps // 10, 16)), 10, axis=0)
    actions = np.array(START_ARM_POSE) + np.cumsum(signs * ACTION_SPEED_LIMITS / 50, axis=0)
    path = tmp_path / "episode_0.hdf5"
    attrs = {"task_name": "sim_transfer_cube", "seed": 0, "success": False}
    with EpisodeWriter(path, steps, [], attrs=attrs) as writer:
        for a in actions:
            writer.append(a, np.zeros(16), a, 0.0, np.r_[0, 0, 0, 1.0, 0, 0, 0])
    ep = load_episode(path)
    assert _assert_within_speed_limits(ep.action[:, KIT14_FROM_16], 50) > 0.999  # the source
    for fps in (30, 25, 17, 1):
        resampled = frame_values(ep, "kit14", fps)["action"].astype(np.float64)
        assert resampled.shape == (steps * fps // 50, 14)
        if fps > 1:
            assert _assert_within_speed_limits(resampled, fps) > 0.99


@pytest.mark.parametrize("source", [50, 60, 30, 7])
def test_frame_map_follows_the_rule_exactly(source):
    """frame_map against the rule in exact fractions, every rate up to the source's."""
    for fps in range(1, source + 1):
        for steps in (1, 2, 3, 7, 20):
            frames = frame_map(steps, source, fps)
            assert frames.length == math.floor(Fraction(steps * fps, source))
            for k in range(frames.length + 1):
                obs = Fraction(k * source, fps)  # t_k in source steps
                act = Fraction((k + 1) * source, fps) - 1  # t_k + 1/N - dt in source steps
                if k == frames.length:  # the next frame would need an action past the end
                    assert act > steps - 1
                    break
                assert act <= steps - 1 and obs <= steps - 1
                assert frames.obs_index[k] == math.floor(obs)
                assert frames.obs_frac[k] == float(obs - math.floor(obs))
                assert frames.action_index[k] == math.floor(act)
                assert frames.action_frac[k] == float(act - math.floor(act))
                image = int(frames.image_index[k])  # nearest; a tie takes the earlier
                assert abs(image - obs) <= Fraction(1, 2) and (image - obs != Fraction(1, 2))
                end = Fraction((k + 1) * source, fps)  # the frame's end, in source steps
                j = int(frames.reward_index[k])
                assert j < end <= j + 1 and 0 <= j < steps
    same = frame_map(9, source, source)  # at the recording rate: every step itself
    assert np.array_equal(same.obs_index, np.arange(9)) and not same.obs_frac.any()
    assert np.array_equal(same.action_index, np.arange(9)) and not same.action_frac.any()
    assert np.array_equal(same.image_index, np.arange(9))
    assert np.array_equal(same.reward_index, np.arange(9))


# -- bad step periods, output folders that refuse the writes ------------------------------------


def _one_error(capfd) -> str:
    """The one ``error:`` line of a failed run (stderr at the file-descriptor level, library
    noise included); no traceback."""
    out, err = capfd.readouterr()
    assert "Traceback" not in err + out
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    return lines[0]


def _export(data: Path, out: Path, *extra: str) -> int:
    return cli(["--data_dir", str(data), "--output", str(out), "--repo_id", "me/ds", *extra])


def _temps(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.name.endswith((".tmp", ".old")))


def _frames_written(build: Path) -> bool:
    """Whether the build folder holds frames; False while it is missing or once it is
    renamed away between the check and the walk."""
    try:
        return any(build.rglob("*.parquet"))
    except FileNotFoundError:
        return False


@pytest.mark.parametrize("dt", [0.0, -0.02, float("nan"), float("inf"), "fast"])
def test_bad_step_period_is_one_line_exit_2(tmp_path, capfd, make_episode, dt):
    data = tmp_path / "eps"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    with h5py.File(data / "episode_0.hdf5", "r+") as f:
        f.attrs["dt"] = dt
    assert _export(data, tmp_path / "ds") == 2
    line = _one_error(capfd)
    assert "episode_0.hdf5: step period dt=" in line and "not a positive number" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eps"]


def test_read_only_output(tmp_path, fs_faults, capfd, make_episode):
    data = tmp_path / "eps"
    make_episode(data / "episode_0.hdf5", 3, ["top"], seed=0)
    with fs_faults.tmpfs(tmp_path / "ro", read_only=True, folders=("ds",)) as ro:
        for out in (ro / "ds", ro / "new" / "ds"):  # an empty folder there, or none
            assert _export(data, out) == 2
            line = _one_error(capfd)
            assert "Read-only file system (EROFS)" in line and "choose another --output" in line
        assert os.listdir(ro) == ["ds"] and os.listdir(ro / "ds") == []


def test_full_disk(tmp_path, fs_faults, capfd):
    data = tmp_path / "eps"
    _noise_episodes(data, episodes=2, steps=20)
    with fs_faults.tmpfs(tmp_path / "full", size="64k") as full:
        assert _export(data, full / "ds") == 2
        line = _one_error(capfd)
        assert f"export to {full / 'ds'} failed: No space left on device (ENOSPC)" in line
        assert "the partial dataset was removed" in line and "free some disk space" in line
        assert os.listdir(full) == []  # the build folder is gone


def test_immutable_parent(tmp_path, fs_faults, capfd, make_episode):
    data = tmp_path / "eps"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    with fs_faults.immutable(tmp_path / "frozen") as frozen:
        assert _export(data, frozen / "ds") == 2
        line = _one_error(capfd)
        assert "Operation not permitted (EPERM)" in line and "immutable" in line
        assert os.listdir(frozen) == []


def test_output_on_a_mount_point(tmp_path, fs_faults, capfd, make_episode):
    data = tmp_path / "eps"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    with fs_faults.tmpfs(tmp_path / "mnt", size="1m") as mnt:
        assert _export(data, mnt) == 2
        assert "is a mount point; give a folder inside it" in _one_error(capfd)
        assert _export(data, mnt / "ds") == 0
    assert _temps(tmp_path) == []


def test_rerun_removes_a_killed_runs_build_folder(tmp_path, capfd, make_episode):
    """SIGKILL runs no handler: the next export empties and reuses the build folder."""
    data, out = tmp_path / "eps", tmp_path / "ds"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    stale = tmp_path / ".ds.tmp"
    (stale / "data" / "chunk-000").mkdir(parents=True)
    (stale / "data" / "chunk-000" / "file-000.parquet").write_bytes(b"half a file")
    assert _export(data, out, "--fps", "50") == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 3


def test_rerun_restores_a_dataset_a_killed_overwrite_moved_aside(tmp_path, capfd, make_episode):
    """Killed between moving the old dataset aside and moving the new one in: the next run
    puts the old one back (never lost), then behaves as with that dataset in place."""
    data, out = tmp_path / "eps", tmp_path / "ds"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    assert _export(data, out, "--fps", "50") == 0
    out.rename(tmp_path / ".ds.old")
    (tmp_path / ".ds.tmp").mkdir()
    capfd.readouterr()
    assert _export(data, out) == 2
    assert "is not empty; choose another --output or pass --overwrite" in _one_error(capfd)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 3
    make_episode(data / "episode_1.hdf5", 4, [], seed=1)
    (tmp_path / ".ds.old").mkdir()  # moved aside, new one in place, old not yet removed
    assert _export(data, out, "--overwrite", "--fps", "50") == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]
    assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 7


def test_another_export_to_the_same_output(tmp_path, capfd, make_episode):
    data, out = tmp_path / "eps", tmp_path / "ds"
    make_episode(data / "episode_0.hdf5", 3, [], seed=0)
    (tmp_path / ".ds.tmp").mkdir()
    with folder_lock(tmp_path / ".ds.tmp"):
        assert _export(data, out) == 2
        assert (tmp_path / ".ds.tmp").is_dir()  # the other export's folder is left alone
    assert "another export is writing" in _one_error(capfd)
    assert _export(data, out) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]


# -- Ctrl-C and SIGTERM in a real process --------------------------------------------------------


def _noise_episodes(folder: Path, episodes: int = 4, steps: int = 120) -> None:
    """Episodes whose videos take a while to encode: noise images, 2 cameras 96x128."""
    rng = np.random.default_rng(1)
    cams = ["cam_high", "cam_low"]
    attrs = {"task_name": "sim_transfer_cube", "seed": 0, "success": False}
    first = folder / "episode_0.hdf5"
    with EpisodeWriter(first, steps, cams, 96, 128, attrs=attrs) as writer:
        for _ in range(steps):
            images = {c: rng.integers(0, 256, (96, 128, 3), dtype=np.uint8) for c in cams}
            pose = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
            writer.append(rng.normal(size=16), np.zeros(16), np.zeros(16), 0.0, pose, images)
    for k in range(1, episodes):
        shutil.copy(first, folder / f"episode_{k}.hdf5")


def _default_sigint() -> None:  # a background shell may start us with SIGINT ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize(
    ("sig", "status", "name", "overwrite"),
    [(signal.SIGTERM, 143, "SIGTERM", False), (signal.SIGINT, 130, "Ctrl-C", True)],
)
def test_signal_mid_write_leaves_no_temporary_folder(tmp_path, sig, status, name, overwrite):
    data, out = tmp_path / "eps", tmp_path / "ds"
    _noise_episodes(data)
    if overwrite:  # a dataset in place (of the first episode), to be replaced
        first = tmp_path / "first"
        first.mkdir()
        shutil.copy(data / "episode_0.hdf5", first)
        export_lerobot(first, out, "me/ds", progress=False, video=VideoSettings(codec="h264"))
        shutil.rmtree(first)
    cmd = [
        sys.executable,
        "-m",
        "trossen_arm_mujoco.cli",
        "export",
        "--data_dir",
        str(data),
        "--output",
        str(out),
        "--repo_id",
        "me/ds",
        *(["--overwrite"] if overwrite else []),
    ]
    proc = subprocess.Popen(
        cmd,
        cwd=Path(__file__).parents[2],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )
    build = tmp_path / ".ds.tmp"
    deadline = time.time() + 120
    try:  # wait for the first episode's frames in the build folder
        while not _frames_written(build):
            assert proc.poll() is None, proc.communicate()
            assert time.time() < deadline, "no frames written within 120 s"
            time.sleep(0.005)
        proc.send_signal(sig)
        stdout, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == status, err
    assert "Traceback" not in err and stdout == ""
    lines = [line for line in err.splitlines() if line.startswith(("interrupted", "error"))]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"interrupted ({name}): the partial dataset was removed; ")
    assert _temps(tmp_path) == []
    if overwrite:
        assert lines[0].endswith(f"the dataset already in {out} is unchanged")
        assert json.loads((out / "meta/info.json").read_text())["total_frames"] == 72
        assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "eps"]
    else:
        assert lines[0].endswith(f"nothing was written to {out}")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["eps"]


def test_the_action_grippers_are_what_the_controller_executes():
    """The recorder's fully open 0.044 m gripper is exported as the 0.04 m the arm
    controller clips it to; everything else is the file's."""
    action = np.zeros((3, 16))
    action[:, [6, 7, 14, 15]] = [
        [0.044, 0.044, 0.03, 0.03],
        [0.02, 0.02, 0.044, 0.044],
        [0.0, 0.0, 0.04, 0.04],
    ]
    action[:, 0] = [0.1, 0.2, 0.3]
    out = controller_actions(action)
    assert out[:, [6, 7, 14, 15]].max() == 0.04
    assert out[0, 14] == 0.03 and out[2, 6] == 0.0 and list(out[:, 0]) == [0.1, 0.2, 0.3]
    assert action[0, 6] == 0.044  # the caller's array is kept
