"""Episode -> mp4 (labelled camera grid) and joint plots.

Needs the ``video`` extra (PyAV and matplotlib), imported only when used.
Videos are H.264 in yuv420p with even dimensions, so browsers play them; frames are read,
composed and encoded one step at a time, and files appear under their final name only
once complete.

Docs: docs/cli/visualize.md.
"""

from __future__ import annotations

import importlib
import math
import os
from collections.abc import Iterable
from fractions import Fraction
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.data.schema import (
    JOINT_NAMES,
    JOINT_UNITS,
    NUM_JOINTS,
    SINGLE_ARM_LAYOUT,
)
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import atomic_path
from trossen_arm_mujoco.robot.layout import ARM_JOINTS, LAYOUTS

__all__ = [
    "H264_ENCODERS",
    "INSTALL_HINT",
    "CameraGrid",
    "grid_shape",
    "h264_encoder",
    "joint_labels",
    "plot_joints",
    "video_info",
    "write_episode_video",
    "write_frames_video",
]

#: H.264 encoders tried in order.
H264_ENCODERS: tuple[str, ...] = ("libx264", "libopenh264", "h264")

INSTALL_HINT = "pip install 'trossen-arm-mujoco[video]'"


def _require(module: str, package: str) -> ModuleType:
    try:
        return importlib.import_module(module)
    except ImportError:
        raise UserError(
            f"videos and plots need the '{package}' package; install it with: {INSTALL_HINT}"
        ) from None


@lru_cache(maxsize=1)
def h264_encoder() -> str:
    """Name of the first available H.264 encoder of the installed PyAV."""
    av = _require("av", "av")
    for name in H264_ENCODERS:
        try:
            av.codec.Codec(name, "w")
        except Exception:  # unknown codec: its error class differs across PyAV versions
            continue
        return name
    raise UserError(
        f"this PyAV build has no H.264 encoder (tried {', '.join(H264_ENCODERS)}); "
        "install the PyAV wheel from PyPI: pip install --force-reinstall av"
    )


def grid_shape(num_cameras: int) -> tuple[int, int]:
    """``(rows, cols)`` of the camera grid: 1x1, 1x2, 2x2, 2x3, 3x3..."""
    cols = max(1, math.ceil(math.sqrt(num_cameras)))
    rows = max(1, math.ceil(num_cameras / cols))
    return rows, cols


def _label_patch(text: str, tile_h: int, tile_w: int) -> np.ndarray:
    """White camera name on a black box, uint8 ``(h, w, 3)`` no larger than the tile."""
    from PIL import Image, ImageDraw, ImageFont

    size = max(10, tile_h // 24)
    try:
        font: Any = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        font = ImageFont.load_default()
    left, top, right, bottom = ImageDraw.Draw(Image.new("RGB", (1, 1))).textbbox(
        (0, 0), text, font=font
    )
    pad = max(2, size // 4)
    img = Image.new("RGB", (right - left + 2 * pad, bottom - top + 2 * pad))
    ImageDraw.Draw(img).text((pad - left, pad - top), text, fill=(255, 255, 255), font=font)
    return np.asarray(img, dtype=np.uint8)[:tile_h, :tile_w]


class CameraGrid:
    """Composes one frame per camera into a labelled grid image.

    Tiles are as large as the largest camera image; the grid is padded to even height and
    width (yuv420p). :meth:`compose` reuses one buffer.

    Args:
        camera_names: cameras in grid order (row-major).
        image_shapes: ``{camera: (H, W, 3)}``.
    """

    def __init__(self, camera_names: list[str], image_shapes: dict[str, tuple[int, ...]]) -> None:
        if not camera_names:
            raise UserError("a camera grid needs at least one camera")
        self.camera_names = list(camera_names)
        self.tile_h = max(image_shapes[cam][0] for cam in camera_names)
        self.tile_w = max(image_shapes[cam][1] for cam in camera_names)
        self.rows, self.cols = grid_shape(len(camera_names))
        self.height = _even(self.rows * self.tile_h)
        self.width = _even(self.cols * self.tile_w)
        self._buffer = np.zeros((self.height, self.width, 3), dtype=np.uint8)
        self._labels = {cam: _label_patch(cam, self.tile_h, self.tile_w) for cam in camera_names}

    def compose(self, frames: dict[str, np.ndarray]) -> np.ndarray:
        """Grid image uint8 ``(height, width, 3)`` of ``{camera: uint8 (H, W, 3)}``."""
        for i, cam in enumerate(self.camera_names):
            y, x = (i // self.cols) * self.tile_h, (i % self.cols) * self.tile_w
            frame = frames[cam]
            h, w = frame.shape[:2]
            tile = self._buffer[y : y + self.tile_h, x : x + self.tile_w]
            tile[:h, :w] = frame
            label = self._labels[cam]
            tile[: label.shape[0], : label.shape[1]] = label
        return self._buffer


def _even(n: int) -> int:
    return n + (n % 2)


def write_episode_video(
    episode: Episode,
    out_path: str | os.PathLike[str],
    fps: float = 50,
    cameras: list[str] | None = None,
) -> Path:
    """Write one H.264 mp4 of all (or the given) cameras of ``episode`` as a labelled grid.

    Args:
        episode: a loaded episode with images (frames are read lazily, one step at a time).
        out_path: the mp4 to write (replaced if it exists; written to a temp name first).
        fps: frames per second (50 = real time at ``DT = 0.02`` s).
        cameras: subset / order of cameras; default all, in recording order.

    Returns:
        ``out_path``.
    """
    _require("av", "av")
    cams = list(episode.camera_names if cameras is None else cameras)
    unknown = [cam for cam in cams if cam not in episode.camera_names]
    if unknown:
        raise UserError(
            f"{episode.path.name}: unknown cameras {unknown}; "
            f"valid: {', '.join(episode.camera_names) or '(none recorded)'}"
        )
    if not cams:
        raise UserError(f"{episode.path.name} has no camera images; nothing to put in a video")
    if not (isinstance(fps, int | float) and 0 < fps <= 1000):
        raise UserError(f"fps must be in (0, 1000], got {fps}")
    grid = CameraGrid(cams, episode.image_shapes)
    with episode.open_frames() as frames:
        images = (grid.compose(frames.step(t, cams)) for t in range(episode.num_steps))
        return write_frames_video(images, out_path, fps, grid.height, grid.width)


def write_frames_video(
    frames: Iterable[np.ndarray],
    out_path: str | os.PathLike[str],
    fps: float,
    height: int,
    width: int,
) -> Path:
    """Encode RGB frames as one H.264 mp4, written to a temp name and renamed onto
    ``out_path`` when complete.

    Args:
        frames: uint8 (height, width, 3) images.
        out_path: the mp4 to write.
        fps: frames per second.
        height: image height (pixels, even).
        width: image width (pixels, even).

    Returns:
        ``out_path``.
    """
    av = _require("av", "av")
    encoder = h264_encoder()
    out_path = Path(out_path).expanduser()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    rate = Fraction(fps).limit_denominator(1001)
    with atomic_path(out_path) as tmp:
        with av.open(str(tmp), "w", format="mp4", options={"movflags": "+faststart"}) as out:
            stream = out.add_stream(encoder, rate=rate)
            stream.width, stream.height = width, height
            stream.pix_fmt = "yuv420p"
            if encoder == "libx264":
                stream.options = {"crf": "20", "preset": "veryfast"}
            else:
                stream.bit_rate = 4_000_000
            for image in frames:
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
                out.mux(stream.encode(frame))
            out.mux(stream.encode(None))
    return out_path


def video_info(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Decode an mp4 completely: ``{"codec", "width", "height", "frames", "pix_fmt"}``."""
    av = _require("av", "av")
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = sum(1 for _ in container.decode(stream))
        ctx = stream.codec_context
        return {
            "codec": ctx.name,
            "width": ctx.width,
            "height": ctx.height,
            "frames": frames,
            "pix_fmt": ctx.pix_fmt,
        }


def _step_period(episode: Episode) -> float | None:
    """The episode's ``dt`` when it is a positive number, else None (plot against steps)."""
    try:
        dt = float(episode.dt)
    except (TypeError, ValueError):
        return None
    return dt if math.isfinite(dt) and dt > 0 else None


def joint_labels(episode: Episode) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(names, units) of the episode's qpos/action values: its layout's (root attribute
    ``layout``, e.g. ``mobileai``), else the vendor's 16; a single arm's 7 (``widowxai``)
    are ``joint_0`` .. ``joint_5``, ``gripper``."""
    name = str(episode.attrs.get("layout", ""))
    layout = LAYOUTS.get(name)
    if layout is not None:
        return layout.names, layout.units
    if name == SINGLE_ARM_LAYOUT:
        return (*ARM_JOINTS, "gripper"), ("rad",) * 6 + ("m",)
    return JOINT_NAMES, JOINT_UNITS


def plot_joints(episode: Episode, out_png: str | os.PathLike[str], dpi: int = 80) -> Path:
    """Write one PNG with a subplot per joint (16): qpos and action against time (s), or
    against the step index when the episode's ``dt`` is not a positive number. Titles and
    units are the episode's layout's (root attribute ``layout``: a Mobile AI episode's
    ``mobileai`` rows are the arms' 14 values, then ``x.vel`` m/s, ``theta.vel`` rad/s;
    without it the vendor's 16).

    Args:
        episode: the episode, read.
        out_png: the PNG to write.
        dpi: the figure's resolution.

    Returns:
        ``out_png`` (replaced if it exists; written to a temp name first).
    """
    _require("matplotlib", "matplotlib")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out_png = Path(out_png).expanduser()
    out_png.parent.mkdir(parents=True, exist_ok=True)
    dt = _step_period(episode)
    time = np.arange(episode.num_steps) * (1.0 if dt is None else dt)
    fig = Figure(figsize=(16, 12), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(4, 4, sharex=True).ravel()
    names, units = joint_labels(episode)
    n = min(NUM_JOINTS, episode.qpos.shape[1], len(names))  # 7 for a single arm
    for j, ax in enumerate(axes[:n]):
        ax.plot(time, episode.qpos[:, j], label="qpos", linewidth=1.2)
        ax.plot(time, episode.action[:, j], "--", label="action", linewidth=1.0)
        ax.set_title(names[j], fontsize=9)
        ax.set_ylabel(units[j], fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes[n:]:
        ax.set_visible(False)
    for ax in axes[max(0, n - 4) : n]:  # the bottom plot of each column
        ax.set_xlabel("time (s)" if dt is not None else "step (no valid dt)", fontsize=8)
        ax.tick_params(labelbottom=True)
    axes[0].legend(fontsize=7, loc="best")
    title = episode.path.name
    if "success" in episode.attrs:
        title += f"  (success: {episode.attrs['success']})"
    fig.suptitle(title)
    with atomic_path(out_png) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return out_png
