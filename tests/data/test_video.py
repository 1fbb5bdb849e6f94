"""Episode videos (H.264 camera grid) and joint plots."""

from __future__ import annotations

import sys
import tracemalloc

import h5py
import numpy as np
import pytest
from PIL import Image

from trossen_arm_mujoco.data import video
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.video import (
    CameraGrid,
    grid_shape,
    h264_encoder,
    plot_joints,
    video_info,
    write_episode_video,
)
from trossen_arm_mujoco.errors import UserError


@pytest.mark.parametrize(
    "n, shape", [(1, (1, 1)), (2, (1, 2)), (3, (2, 2)), (4, (2, 2)), (5, (2, 3)), (9, (3, 3))]
)
def test_grid_shape(n, shape):
    assert grid_shape(n) == shape


def test_camera_grid_labels_and_even_size():
    grid = CameraGrid(
        ["cam_a", "cam_b", "cam_c"], {c: (25, 33, 3) for c in "cam_a cam_b cam_c".split()}
    )
    assert (grid.height, grid.width) == (50, 66)
    frames = {cam: np.full((25, 33, 3), 100, np.uint8) for cam in grid.camera_names}
    image = grid.compose(frames)
    assert image.shape == (50, 66, 3) and image.dtype == np.uint8
    assert image[:12, :33].max() > 200  # white label text on the first tile
    assert image[20, 20].tolist() == [100, 100, 100]  # frame content below the label
    assert image[30, 40].tolist() == [0, 0, 0]  # the unused fourth tile stays black


@pytest.mark.py312  # PyAV 15 in the LeRobot venv (tests/conftest.py)
def test_encoder_is_h264():
    assert h264_encoder() in video.H264_ENCODERS


@pytest.mark.py312  # PyAV 15 in the LeRobot venv (tests/conftest.py)
def test_video_of_written_episode(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=6, height=24, width=32)
    ep = load_episode(path)
    out = write_episode_video(ep, tmp_path / "videos" / "episode_0.mp4", fps=50)
    info = video_info(out)
    assert info == {"codec": "h264", "width": 64, "height": 48, "frames": 6, "pix_fmt": "yuv420p"}
    assert sorted(p.name for p in out.parent.iterdir()) == ["episode_0.mp4"]


@pytest.mark.py312  # PyAV 15 in the LeRobot venv (tests/conftest.py)
def test_video_of_camera_subset_and_odd_size(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=3, cams=["a", "b", "c"], height=25, width=33)
    ep = load_episode(path)
    info = video_info(write_episode_video(ep, tmp_path / "v.mp4", fps=10, cameras=["c"]))
    assert (info["width"], info["height"], info["frames"]) == (34, 26, 3)
    with pytest.raises(UserError, match="unknown cameras"):
        write_episode_video(ep, tmp_path / "w.mp4", cameras=["zzz"])
    with pytest.raises(UserError, match="fps"):
        write_episode_video(ep, tmp_path / "w.mp4", fps=0)
    assert not (tmp_path / "w.mp4").exists()


@pytest.mark.py312  # PyAV 15 in the LeRobot venv (tests/conftest.py)
def test_video_of_vendor_episode(tmp_path, vendor_4cams):
    out = write_episode_video(load_episode(vendor_4cams), tmp_path / "episode_0.mp4")
    info = video_info(out)
    assert (info["codec"], info["width"], info["height"], info["frames"]) == ("h264", 1280, 960, 5)


def test_video_without_images_is_a_user_error(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=2, cams=[])
    with pytest.raises(UserError, match="no camera images"):
        write_episode_video(load_episode(path), tmp_path / "x.mp4")


def test_plot_joints(tmp_path, make_episode, vendor_no_images):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=5, cams=[])
    for ep in (load_episode(path), load_episode(vendor_no_images)):
        out = plot_joints(ep, tmp_path / "plots" / f"{ep.path.stem}.png")
        with Image.open(out) as img:
            assert img.format == "PNG" and img.size[0] > 600 and img.size[1] > 400
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == [
        "episode_0.png",
        "vendor_transfer_cube_600steps_noimages.png",
    ]


def test_missing_av_gives_install_hint(tmp_path, make_episode, monkeypatch):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=1, cams=["a"])
    monkeypatch.setitem(sys.modules, "av", None)  # import av -> ImportError
    h264_encoder.cache_clear()
    try:
        with pytest.raises(UserError, match=r"pip install 'trossen-arm-mujoco\[video\]'"):
            write_episode_video(load_episode(path), tmp_path / "x.mp4")
    finally:
        h264_encoder.cache_clear()
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(UserError, match="matplotlib"):
        plot_joints(load_episode(path), tmp_path / "x.png")


def test_video_memory_stays_flat(tmp_path, make_episode):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=60, cams=["a", "b"], height=120, width=160)  # 6.9 MB images
    ep = load_episode(path)
    write_episode_video(ep, tmp_path / "warmup.mp4")
    tracemalloc.start()
    try:
        write_episode_video(ep, tmp_path / "episode_0.mp4")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2_000_000


def test_failed_video_keeps_the_old_file_and_leaves_no_temp(tmp_path, make_episode, monkeypatch):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=4, cams=["a"], height=24, width=32)
    out = tmp_path / "videos" / "episode_0.mp4"
    out.parent.mkdir()
    out.write_bytes(b"previous video")
    real_compose = video.CameraGrid.compose
    calls = []

    def compose_then_fail(self, frames):
        calls.append(1)
        if len(calls) == 3:
            raise OSError("disk full")
        return real_compose(self, frames)

    monkeypatch.setattr(video.CameraGrid, "compose", compose_then_fail)
    with pytest.raises(OSError, match="disk full"):
        write_episode_video(load_episode(path), out)
    assert out.read_bytes() == b"previous video"
    assert sorted(p.name for p in out.parent.iterdir()) == ["episode_0.mp4"]


def test_failed_plot_keeps_the_old_file_and_leaves_no_temp(tmp_path, make_episode, monkeypatch):
    from matplotlib.figure import Figure

    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=3, cams=[])
    out = tmp_path / "episode_0_joints.png"
    out.write_bytes(b"previous plot")

    def savefig_then_fail(self, fname, **kwargs):
        with open(fname, "wb") as f:
            f.write(b"\x89PNG partial")
        raise OSError("disk full")

    monkeypatch.setattr(Figure, "savefig", savefig_then_fail)
    with pytest.raises(OSError, match="disk full"):
        plot_joints(load_episode(path), out)
    assert out.read_bytes() == b"previous plot"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episode_0.hdf5", "episode_0_joints.png"]


@pytest.mark.parametrize("dt", [0.0, -0.02, float("nan"), "fast"])
def test_plot_joints_with_an_invalid_dt_plots_against_steps(tmp_path, make_episode, dt):
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=4, cams=[])
    with h5py.File(path, "r+") as f:
        f.attrs["dt"] = dt
    out = plot_joints(load_episode(path), tmp_path / "episode_0_joints.png")
    with Image.open(out) as img:
        assert img.format == "PNG"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episode_0.hdf5", "episode_0_joints.png"]
    assert video._step_period(load_episode(path)) is None


def test_interrupted_video_leaves_no_temp(tmp_path, make_episode, monkeypatch):
    """Ctrl-C (or SIGTERM, which run_cli raises the same way) mid-video: no file, no temp."""
    path = tmp_path / "episode_0.hdf5"
    make_episode(path, num_steps=5, cams=["a"], height=24, width=32)
    real_compose = video.CameraGrid.compose
    calls = []

    def compose_then_interrupt(self, frames):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real_compose(self, frames)

    monkeypatch.setattr(video.CameraGrid, "compose", compose_then_interrupt)
    out = tmp_path / "videos" / "episode_0.mp4"
    with pytest.raises(KeyboardInterrupt):
        write_episode_video(load_episode(path), out)
    assert list(out.parent.iterdir()) == []
