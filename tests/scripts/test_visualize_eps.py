"""visualize_eps: mp4 + joint plots per episode, one-line errors with exit status 2."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco import cli as top_cli
from trossen_arm_mujoco.data.video import video_info
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.scripts import visualize_eps

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "fixtures"
CAMS = ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]


def _write(path: Path, num_steps: int = 4, cams=CAMS, h: int = 24, w: int = 32) -> None:
    rng = np.random.default_rng(0)
    attrs = {"task_name": "t", "seed": 0, "success": True, "box_pose": [0, 0, 0, 1, 0, 0, 0]}
    with EpisodeWriter(path, num_steps, cams, h, w, attrs=attrs) as writer:
        for _ in range(num_steps):
            images = {c: rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for c in cams}
            writer.append(rng.normal(size=16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7), images)


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "trossen_arm_mujoco.scripts.visualize_eps", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )


def _error_line(err: str) -> str:
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    return lines[0]


def test_videos_and_plots(tmp_path, capsys):
    data = tmp_path / "sim_transfer_cube"
    _write(data / "episode_0.hdf5", num_steps=5)
    _write(data / "episode_1.hdf5", num_steps=3, cams=[])
    rc = visualize_eps.cli(["--root_dir", str(tmp_path), "--data_dir", "sim_transfer_cube"])
    out = capsys.readouterr().out
    assert rc == 0
    videos = data / "videos"
    assert sorted(p.name for p in videos.iterdir()) == [
        "episode_0.mp4",
        "episode_0_joints.png",
        "episode_1_joints.png",
    ]
    info = video_info(videos / "episode_0.mp4")
    assert (info["codec"], info["frames"], info["width"], info["height"]) == ("h264", 5, 64, 48)
    assert (videos / "episode_0_joints.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "no camera images" in out and "episode_1.hdf5" in out
    assert str(videos) in out


def test_single_episode_absolute_output_and_fps(tmp_path, capsys):
    _write(tmp_path / "episode_0.hdf5")
    _write(tmp_path / "episode_2.hdf5", num_steps=2, cams=["cam_high"])
    out_dir = tmp_path / "elsewhere"
    argv = ["--data_dir", str(tmp_path), "--output_dir", str(out_dir), "--episode_idx", "2"]
    assert visualize_eps.cli([*argv, "--fps", "25"]) == 0
    assert sorted(p.name for p in out_dir.iterdir()) == ["episode_2.mp4", "episode_2_joints.png"]
    info = video_info(out_dir / "episode_2.mp4")
    assert (info["frames"], info["width"], info["height"]) == (2, 32, 24)
    assert visualize_eps.cli(["--data_dir", str(tmp_path), "--episode_idx", "5"]) == 2
    assert "no episode 5" in _error_line(capsys.readouterr().err)


def test_vendor_episodes(tmp_path):
    shutil.copy(FIXTURES / "vendor_episode_5steps_4cams.hdf5", tmp_path / "episode_0.hdf5")
    shutil.copy(
        FIXTURES / "vendor_transfer_cube_600steps_noimages.hdf5", tmp_path / "episode_1.hdf5"
    )
    assert visualize_eps.main(["--data_dir", str(tmp_path)]) == 0
    info = video_info(tmp_path / "videos" / "episode_0.mp4")
    assert (info["codec"], info["frames"], info["width"], info["height"]) == ("h264", 5, 1280, 960)
    assert (tmp_path / "videos" / "episode_1_joints.png").is_file()


def test_missing_folder_and_no_episodes(tmp_path, capsys):
    assert visualize_eps.cli(["--data_dir", str(tmp_path / "nope")]) == 2
    assert "data folder not found" in _error_line(capsys.readouterr().err)
    (tmp_path / ".episode_0.hdf5.tmp").write_bytes(b"partial")
    assert visualize_eps.cli(["--data_dir", str(tmp_path)]) == 2
    assert "no episode_<k>.hdf5 files" in _error_line(capsys.readouterr().err)
    assert not (tmp_path / "videos").exists()


@pytest.mark.parametrize("content", [b"not hdf5 at all" * 100, None], ids=["garbage", "truncated"])
def test_corrupt_file_subprocess(tmp_path, content):
    path = tmp_path / "episode_0.hdf5"
    if content is None:  # truncated copy of a valid file
        _write(path, num_steps=10, h=48, w=64)
        content = path.read_bytes()[: path.stat().st_size // 2]
    path.write_bytes(content)
    proc = _run("--data_dir", str(tmp_path))
    assert proc.returncode == 2
    line = _error_line(proc.stderr)
    assert "episode_0.hdf5" in line and "not a readable HDF5" in line
    assert proc.stderr.strip() == line


def test_top_level_command_dispatches(tmp_path, capsys):
    _write(tmp_path / "episode_0.hdf5", num_steps=2, cams=[])
    assert top_cli.main(["visualize", "--data_dir", str(tmp_path)]) == 0
    assert (tmp_path / "videos" / "episode_0_joints.png").is_file()
    assert top_cli.main(["visualize", "--data_dir", str(tmp_path / "x")]) == 2
    _error_line(capsys.readouterr().err)


def test_run_as_file(tmp_path):
    _write(tmp_path / "episode_0.hdf5", num_steps=2, cams=[])
    script = REPO / "trossen_arm_mujoco" / "scripts" / "visualize_eps.py"
    proc = subprocess.run(
        [sys.executable, str(script), "--data_dir", str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "wrote 0 video(s) and 1 joint plot(s)" in proc.stdout
