"""Exports loaded by the real ``LeRobotDataset`` (LeRobot needs Python >= 3.12).

LeRobot cannot be installed next to this package's Python 3.11 environment, so the check
runs in a separate interpreter: ``TROSSEN_LEROBOT_PYTHON`` names a Python with
``lerobot[dataset]`` installed (``.ci/run`` creates one and sets it). Five exports, all in
the default layout (the real kit's 14 values), are loaded with the pyav and torchcodec video
backends:

- ``plugin``: the default export of the recorder episodes: what ``lerobot-record`` writes
  with Trossen's plugin (``bi_widowxai_follower_robot``, 30 fps, ``action``,
  ``observation.state`` and the cameras only).
- ``recorded``: recorder episodes (2 x 20 steps, 2 cameras 48x64, gzip images) at the
  recording rate with the sim's features (``--fps 50 --sim_features``, the features every
  export had before the plugin's became the default), as H.264 yuv444p: frames within PSNR
  35 dB of the HDF5 images.
- ``recorded_av1``: the same with the default encoding (AV1 yuv420p, as LeRobot): at 48x64
  half-resolution colour caps PSNR near 33 dB, so the bound is 28 dB here.
- ``recorded_30``: the recorder episodes resampled to 30 fps (``fps=30``, the real kit's
  rate) with the sim's features, H.264 yuv444p: 2 x 12 frames, each image the source frame
  the export chose.
- ``rolled``: written episodes (at the recording rate, with the sim's features) with a
  moving square (float32 arrays, gzip and lzf images), one data and video
  file per episode: every frame comes back in its place.

State, velocity, action, environment_state and reward must come back bit for bit as the
float32 values computed from the HDF5 files (``frame_values``: the files' own values at the
recording rate, resampled ones at 30 fps).
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from trossen_arm_mujoco.data.reader import list_episodes, load_episode  # noqa: E402
from trossen_arm_mujoco.export import VideoSettings, export_lerobot  # noqa: E402
from trossen_arm_mujoco.export import lerobot_format as fmt  # noqa: E402
from trossen_arm_mujoco.export.lerobot import controller_actions, frame_values  # noqa: E402
from trossen_arm_mujoco.tasks import registry  # noqa: E402

CHECK = Path(__file__).with_name("lerobot_check.py")
ENV = "TROSSEN_LEROBOT_PYTHON"
BACKENDS = ("pyav", "torchcodec")
HIGH_FIDELITY = VideoSettings(codec="h264", pix_fmt="yuv444p", crf=12)
#: The values of Trossen's LeRobot plugin for the kit (bi_widowxai_follower_robot), in order.
KIT14_NAMES = [
    *(f"left_joint_{i}.pos" for i in range(6)),
    "left_left_carriage_joint.pos",
    *(f"right_joint_{i}.pos" for i in range(6)),
    "right_left_carriage_joint.pos",
]
#: Where each comes from in the HDF5 files' 16 values.
KIT14_FROM_16 = [0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 15]


def _lerobot_python() -> str:
    python = os.environ.get(ENV, "")
    if not python:
        pytest.skip(f"{ENV} is not set: point it at a Python >= 3.12 with lerobot[dataset]")
    if not Path(python).is_file():
        pytest.skip(f"{ENV}={python} does not exist")
    return python


def _expected(data_dir: Path, tasks: list[str], out: Path, fps: int = 50) -> Path:
    """The values the loader must return (see lerobot_check.py), as an .npz: what the export
    computes from the HDF5 files at ``fps``; at the recording rate checked here against the
    files themselves."""
    arrays: dict[str, np.ndarray] = {"tasks": np.array(tasks)}
    for i, (_, path) in enumerate(list_episodes(data_dir)):
        ep = load_episode(path, load_images=True)
        values = frame_values(ep, fps=fps)
        if fps == 50:  # the recording rate: the kit's 14 of the files' 16 values, bit for bit
            assert np.array_equal(
                values["observation.state"], np.float32(ep.qpos)[:, KIT14_FROM_16]
            )
            assert np.array_equal(
                values["action"], np.float32(controller_actions(ep.action))[:, KIT14_FROM_16]
            )
            assert np.array_equal(values["observation.environment_state"], np.float32(ep.env_state))
        arrays[f"state_{i}"] = values["observation.state"]
        arrays[f"velocity_{i}"] = values["observation.velocity"]
        arrays[f"action_{i}"] = values["action"]
        arrays[f"env_state_{i}"] = values["observation.environment_state"]
        arrays[f"reward_{i}"] = values["next.reward"]
        arrays[f"success_{i}"] = values["next.reward"] >= 4
        for cam, frames in ep.images.items():
            arrays[f"images_{cam}_{i}"] = frames[values["image_index"]]
    np.savez(out, **arrays)
    return out


@pytest.fixture(scope="module")
def loaded(request, make_episode, make_float32, tmp_path_factory) -> dict:
    """Export three datasets and load them all in one run of the LeRobot Python."""
    python = _lerobot_python()  # skip before recording when there is no LeRobot
    recorded = request.getfixturevalue("recorded")
    tmp = tmp_path_factory.mktemp("lerobot_load")
    transfer = registry.load("sim_transfer_cube").description
    datasets = []
    for name, video, fps, sim in (
        ("plugin", HIGH_FIDELITY, None, False),
        ("recorded", HIGH_FIDELITY, 50, True),
        ("recorded_av1", VideoSettings(), 50, True),
        ("recorded_30", HIGH_FIDELITY, 30, True),
    ):
        export_lerobot(
            recorded,
            tmp / name,
            f"test/{name}",
            video=video,
            progress=False,
            fps=fps,
            sim_features=sim,
        )
        expected = _expected(recorded, [transfer] * 2, tmp / f"{name}.npz", fps or 30)
        datasets.append({"name": name, "root": str(tmp / name), "repo_id": f"test/{name}"})
        datasets[-1]["expected"] = str(expected)

    rolled = tmp / "rolled_eps"  # float32 arrays in two files, compressed images in two
    for k, (steps, compression) in enumerate(((12, "none"), (9, "gzip"), (10, "lzf"))):
        make_episode(rolled / f"episode_{k}.hdf5", steps, ["top"], k, compression=compression)
        if k:
            make_float32(rolled / f"episode_{k}.hdf5")
    mp = pytest.MonkeyPatch()
    mp.setattr(fmt, "DATA_FILES_SIZE_MB", 1e-6)  # every episode in its own files
    mp.setattr(fmt, "VIDEO_FILES_SIZE_MB", 1e-6)
    try:
        export_lerobot(
            rolled,
            tmp / "rolled",
            "test/rolled",
            video=HIGH_FIDELITY,
            task="stack",
            progress=False,
            fps=50,
            sim_features=True,
        )
    finally:
        mp.undo()
    expected = _expected(rolled, ["stack"] * 3, tmp / "rolled.npz")
    datasets.append(
        {
            "name": "rolled",
            "root": str(tmp / "rolled"),
            "repo_id": "test/rolled",
            "expected": str(expected),
        }
    )

    spec = tmp / "spec.json"
    spec.write_text(json.dumps({"datasets": datasets, "backends": list(BACKENDS)}))
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "HF_HOME": str(tmp / "hf_home")}
    proc = subprocess.run(
        [python, str(CHECK), str(spec)], capture_output=True, text=True, env=env, timeout=600
    )
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return json.loads(lines[-1][len("RESULT ") :])


def _runs(loaded: dict, backend: str) -> dict:
    run = loaded["runs"][backend]
    if "unavailable" in run:
        pytest.skip(f"{backend} cannot load (FFmpeg libraries missing?): {run['unavailable']}")
    return run


DATASETS = {  # name: (episodes, frames, fps, objects in environment_state)
    "recorded": (2, 40, 50, ["box"]),
    "recorded_av1": (2, 40, 50, ["box"]),
    "recorded_30": (2, 24, 30, ["box"]),
    "rolled": (3, 31, 50, ["obj0", "obj1"]),
}


@pytest.mark.parametrize("backend", BACKENDS)
def test_frames_and_arrays_match_the_episodes(loaded, backend):
    run = _runs(loaded, backend)
    parts = ["x", "y", "z", "qw", "qx", "qy", "qz"]
    for name, (episodes, frames, fps, objects) in DATASETS.items():
        got = run[name]
        assert (got["num_episodes"], got["num_frames"], got["fps"]) == (episodes, frames, fps)
        assert got["names"] == {
            "state": KIT14_NAMES,
            "velocity": [n.replace(".pos", ".vel") for n in KIT14_NAMES],
            "action": KIT14_NAMES,
            "env_state": [f"{obj}_{p}" for obj in objects for p in parts],
        }
        zero = {"state": 0.0, "velocity": 0.0, "action": 0.0, "env_state": 0.0, "reward": 0.0}
        assert got["max_abs"] == zero, name
        assert got["shapes"] == {
            "state": [14],
            "velocity": [14],
            "action": [14],
            "env_state": [7 * len(objects)],
            "reward": [],
        }
        assert set(got["dtypes"].values()) == {"float32"}
        assert got["success_equal"] and got["task_equal"]
        assert got["order"] == [[e, t] for e, n in enumerate(_lengths(name)) for t in range(n)]
        assert "observation.state" in got["stats_keys"]
    assert run["recorded"]["cameras"] == ["cam_high", "cam_left_wrist"]
    assert run["recorded"]["tasks"] == [registry.load("sim_transfer_cube").description]


def _lengths(name: str) -> list[int]:
    return {"rolled": [12, 9, 10], "recorded_30": [12, 12], "plugin": [12, 12]}.get(name, [20, 20])


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_default_export_is_what_lerobot_record_writes(loaded, backend):
    """The plugin's robot type, 30 fps, action and state with its names, the cameras, and
    none of the sim's features; the values those the export computes."""
    got = _runs(loaded, backend)["plugin"]
    assert got["robot_type"] == "bi_widowxai_follower_robot"
    assert (got["num_episodes"], got["num_frames"], got["fps"]) == (2, 24, 30)
    assert got["features"] == [
        "action",
        "observation.state",
        "observation.images.cam_high",
        "observation.images.cam_left_wrist",
        "timestamp",
        "frame_index",
        "episode_index",
        "index",
        "task_index",
    ]
    assert got["names"] == {"state": KIT14_NAMES, "action": KIT14_NAMES}
    assert got["max_abs"] == {"state": 0.0, "action": 0.0}
    assert got["order"] == [[e, t] for e, n in enumerate(_lengths("plugin")) for t in range(n)]
    for cam, value in got["min_psnr"].items():
        assert value >= 35.0, (cam, value)


@pytest.mark.parametrize("backend", BACKENDS)
def test_video_frames_within_codec_tolerance(loaded, backend):
    run = _runs(loaded, backend)
    for cam, value in run["recorded"]["min_psnr"].items():
        assert value >= 35.0, (cam, value)
    for cam, value in run["recorded_30"]["min_psnr"].items():
        assert value >= 35.0, (cam, value)
    for cam, value in run["recorded_av1"]["min_psnr"].items():
        assert value >= 28.0, (cam, value)
    assert min(run["rolled"]["min_psnr"].values()) >= 35.0
    assert run["rolled"]["misaligned"] == []
    assert run["recorded"]["misaligned"] == []
    assert run["recorded_30"]["misaligned"] == []
