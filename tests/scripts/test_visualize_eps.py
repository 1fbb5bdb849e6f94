"""visualize_eps: mp4 + joint plots per episode, one-line errors with exit status 2, and
Ctrl-C / SIGTERM that leave no temporary file (exit status 130 / 143)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco import cli as top_cli
from trossen_arm_mujoco.data.video import video_info
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.fileio import folder_lock
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


# -- output folders that refuse the writes -----------------------------------------------------


def _one_error(capfd) -> str:
    """The one ``error:`` line of a failed run (stderr at the file-descriptor level: library
    noise included); no traceback."""
    out, err = capfd.readouterr()
    assert "Traceback" not in err + out
    return _error_line(err)


def _temps(folder: Path) -> list[str]:
    """The temporary files under ``folder``; none when it is gone (the output check creates
    and removes the folder before the run makes it for good)."""
    try:
        return sorted(p.name for p in folder.rglob("*") if p.name.endswith(".tmp"))
    except FileNotFoundError:
        return []


def test_output_dir_is_a_file_or_under_one(tmp_path, capfd):
    _write(tmp_path / "episode_0.hdf5", num_steps=2, cams=["cam_high"])
    (tmp_path / "notes.txt").write_text("x")
    argv = ["--data_dir", str(tmp_path), "--output_dir"]
    assert visualize_eps.cli([*argv, str(tmp_path / "notes.txt")]) == 2
    assert "is a file; give a folder" in _one_error(capfd)
    assert visualize_eps.cli([*argv, str(tmp_path / "notes.txt" / "videos")]) == 2
    line = _one_error(capfd)
    assert "cannot write to --output_dir" in line and "a file is in the way" in line
    assert _temps(tmp_path) == []


def test_output_dir_read_only(tmp_path, fs_faults, capfd):
    _write(tmp_path / "eps" / "episode_0.hdf5", num_steps=2, cams=["cam_high"])
    with fs_faults.tmpfs(tmp_path / "ro", read_only=True) as ro:
        argv = ["--data_dir", str(tmp_path / "eps"), "--output_dir"]
        assert visualize_eps.cli([*argv, str(ro)]) == 2
        line = _one_error(capfd)
        # refused before any episode is read or rendered
        assert f"cannot write to --output_dir {ro}" in line and "Read-only file system" in line
        assert visualize_eps.cli([*argv, str(ro / "videos")]) == 2  # a folder to create
        assert "cannot write to --output_dir" in _one_error(capfd)
        assert os.listdir(ro) == []


def test_output_dir_on_a_full_disk(tmp_path, fs_faults, capfd):
    _write(tmp_path / "eps" / "episode_0.hdf5", num_steps=30, cams=["cam_high"], h=96, w=128)
    with fs_faults.tmpfs(tmp_path / "full", size="48k") as full:
        rc = visualize_eps.cli(["--data_dir", str(tmp_path / "eps"), "--output_dir", str(full)])
        assert rc == 2
        line = _one_error(capfd)
        assert "No space left on device (ENOSPC)" in line and "free some disk space" in line
        assert _temps(full) == []  # the file in progress is removed
        for name in os.listdir(full):  # what was kept is complete
            assert name.endswith((".mp4", ".png"))


def test_output_dir_immutable(tmp_path, fs_faults, capfd):
    _write(tmp_path / "eps" / "episode_0.hdf5", num_steps=2, cams=[])
    with fs_faults.immutable(tmp_path / "frozen") as frozen:
        argv = ["--data_dir", str(tmp_path / "eps"), "--output_dir", str(frozen)]
        assert visualize_eps.cli(argv) == 2
        line = _one_error(capfd)
        assert "Operation not permitted (EPERM)" in line and "immutable" in line
        assert os.listdir(frozen) == []


def test_another_run_holds_the_output_folder(tmp_path, capfd):
    _write(tmp_path / "episode_0.hdf5", num_steps=2, cams=[])
    (tmp_path / "videos").mkdir()
    with folder_lock(tmp_path / "videos"):
        assert visualize_eps.cli(["--data_dir", str(tmp_path)]) == 2
    assert "another visualize is writing into" in _one_error(capfd)
    assert visualize_eps.cli(["--data_dir", str(tmp_path)]) == 0


def test_rerun_removes_its_own_stale_temporary_files(tmp_path):
    """What a run killed with SIGKILL leaves (no handler runs) goes with the next run; the
    recorder's temporary episode in the same folder is not this command's to remove."""
    _write(tmp_path / "episode_0.hdf5", num_steps=2, cams=["cam_high"])
    stale = [".episode_0.mp4.tmp", ".episode_7.mp4.tmp", ".episode_3_joints.png.tmp"]
    for name in stale:
        (tmp_path / name).write_bytes(b"partial")
    (tmp_path / ".episode_1.hdf5.tmp").write_bytes(b"a recording in progress")
    assert visualize_eps.cli(["--data_dir", str(tmp_path), "--output_dir", "."]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".episode_1.hdf5.tmp",
        "episode_0.hdf5",
        "episode_0.mp4",
        "episode_0_joints.png",
    ]


# -- Ctrl-C and SIGTERM in a real process --------------------------------------------------------


def _long_job(folder: Path, episodes: int = 4, steps: int = 120) -> None:
    """Episodes whose video takes a while: noise images (slow to encode), 2 cameras."""
    rng = np.random.default_rng(1)
    cams = ["cam_high", "cam_low"]
    attrs = {"task_name": "t", "seed": 0, "success": True}
    first = folder / "episode_0.hdf5"
    with EpisodeWriter(first, steps, cams, 96, 128, attrs=attrs) as writer:
        for _ in range(steps):
            images = {c: rng.integers(0, 256, (96, 128, 3), dtype=np.uint8) for c in cams}
            writer.append(rng.normal(size=16), np.zeros(16), np.zeros(16), 0.0, np.zeros(7), images)
    for k in range(1, episodes):
        shutil.copy(first, folder / f"episode_{k}.hdf5")


def _default_sigint() -> None:  # a background shell may start us with SIGINT ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize(
    ("sig", "status", "name"), [(signal.SIGTERM, 143, "SIGTERM"), (signal.SIGINT, 130, "Ctrl-C")]
)
def test_signal_mid_write_leaves_no_temporary_file(tmp_path, sig, status, name):
    data = tmp_path / "eps"
    _long_job(data)
    videos = data / "videos"
    proc = subprocess.Popen(
        [sys.executable, "-m", "trossen_arm_mujoco.cli", "visualize", "--data_dir", str(data)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )
    deadline = time.time() + 120
    try:  # wait for a finished file and the next one in progress
        while not (videos.is_dir() and _temps(videos) and any(videos.glob("episode_*.mp4"))):
            assert proc.poll() is None, proc.communicate()
            assert time.time() < deadline, "no file in progress within 120 s"
            time.sleep(0.005)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == status, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith(("interrupted", "error"))]
    assert len(lines) == 1 and lines[0].startswith(f"interrupted ({name}): kept "), err
    assert "the file in progress was removed" in lines[0]
    assert _temps(videos) == []
    kept = sorted(p.name for p in videos.iterdir())
    assert kept and "episode_0.mp4" in kept
    for mp4 in videos.glob("*.mp4"):  # every file kept is complete
        assert video_info(mp4)["frames"] == 120


def test_a_file_published_just_before_the_stop_counts_as_kept(tmp_path):
    """A signal can land after a file's rename and before the run notes it as finished: the
    note still counts it (its modification time changed), and only it."""
    from trossen_arm_mujoco.scripts.visualize_eps import _kept

    video = tmp_path / "episode_0.mp4"
    current = [(video, None)]  # not there before the run
    assert _kept([], tmp_path, current).startswith("no file was finished")
    video.write_bytes(b"finished")  # renamed into place; the stop came before the note
    assert _kept([], tmp_path, current).startswith("kept 1 finished video(s) and 0 joint")
    old = tmp_path / "episode_1.mp4"
    old.write_bytes(b"from an earlier run")
    assert _kept([], tmp_path, [(old, old.stat().st_mtime_ns)]).startswith("no file was")
