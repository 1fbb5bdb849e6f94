"""Camera frames -> the mp4 files of a LeRobot dataset (PyAV).

One :class:`CameraVideo` per camera appends the episodes one after the other to
``videos/<key>/chunk-CCC/file-FFF.mp4``; frame ``i`` of a file is at ``i / fps`` s, so an
episode's frame ``t`` is at ``from_timestamp + t / fps``. A file at the size limit is closed
and the next episode starts the next file. The default encoding is LeRobot's own: AV1
(libsvtav1), yuv420p, a keyframe every 2 frames, CRF 30; H.264 with yuv444p keeps full
colour. Every call into the encoder restores the calling thread's scheduling afterwards
(:func:`kept_scheduling`; SVT-AV1 run as root switches it to real-time).

Docs: docs/cli/export.md; why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.export.lerobot_format import FileIndex

__all__ = [
    "DEFAULT_CRF",
    "ENCODERS",
    "MAX_CRF",
    "PIX_FMTS",
    "SVTAV1_PRESET",
    "CameraVideo",
    "VideoSettings",
    "kept_scheduling",
]

#: Codec choice -> PyAV encoder name, and its default CRF.
ENCODERS: dict[str, str] = {"libsvtav1": "libsvtav1", "h264": "libx264"}
DEFAULT_CRF: dict[str, int] = {"libsvtav1": 30, "h264": 23}
MAX_CRF: dict[str, int] = {"libsvtav1": 63, "h264": 51}
PIX_FMTS: tuple[str, ...] = ("yuv420p", "yuv444p")
#: libsvtav1 speed preset (LeRobot's default: 12, the fastest).
SVTAV1_PRESET = 12


@contextmanager
def kept_scheduling() -> Iterator[None]:
    """The calling thread's scheduling policy and priority as they were before the block
    (an encoder may change them; see the module docstring)."""
    try:
        policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    except (AttributeError, OSError):  # not Linux
        yield
        return
    try:
        yield
    finally:
        if os.sched_getscheduler(0) != policy:
            try:
                os.sched_setscheduler(0, policy, param)
            except OSError:
                pass


def _keeps_scheduling(method: Callable) -> Callable:
    @functools.wraps(method)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with kept_scheduling():
            return method(*args, **kwargs)

    return wrapper


@dataclass(frozen=True)
class VideoSettings:
    """How camera frames are encoded.

    Attributes:
        codec: ``"libsvtav1"`` (AV1, LeRobot's default) or ``"h264"`` (libx264).
        pix_fmt: ``"yuv420p"`` (half-resolution colour; any player) or ``"yuv444p"``
            (full colour; h264 only).
        crf: quality, lower is better and larger (None: 30 for AV1, 23 for H.264).
        gop: frames between keyframes (2: fast random access, as LeRobot).
    """

    codec: str = "libsvtav1"
    pix_fmt: str = "yuv420p"
    crf: int | None = None
    gop: int = 2

    def __post_init__(self) -> None:
        if self.codec not in ENCODERS:
            raise UserError(
                f"unknown video codec '{self.codec}'; valid: {', '.join(sorted(ENCODERS))}"
            )
        if self.pix_fmt not in PIX_FMTS:
            raise UserError(f"unknown pixel format '{self.pix_fmt}'; valid: {', '.join(PIX_FMTS)}")
        if self.codec == "libsvtav1" and self.pix_fmt != "yuv420p":
            raise UserError("libsvtav1 encodes yuv420p only; for yuv444p use --vcodec h264")
        top = MAX_CRF[self.codec]
        if self.crf is not None and not 0 <= self.crf <= top:
            raise UserError(f"--crf for {self.codec} must be in 0..{top}, got {self.crf}")
        if self.gop < 1:
            raise UserError(f"gop must be at least 1, got {self.gop}")

    @property
    def quality(self) -> int:
        """The CRF used."""
        return DEFAULT_CRF[self.codec] if self.crf is None else int(self.crf)

    def options(self) -> dict[str, str]:
        """Encoder options for PyAV."""
        opts = {"g": str(self.gop), "crf": str(self.quality)}
        if self.codec == "libsvtav1":
            opts["preset"] = str(SVTAV1_PRESET)
        return opts

    def info(self, height: int, width: int, fps: int) -> dict[str, Any]:
        """The ``info`` block of a video feature in info.json.

        Args:
            height: image height (pixels).
            width: image width (pixels).
            fps: frames per second of the video.
        """
        av = require("av")
        codec = av.codec.Codec(ENCODERS[self.codec], "w").canonical_name
        info: dict[str, Any] = {
            "video.height": int(height),
            "video.width": int(width),
            "video.codec": codec,
            "video.pix_fmt": self.pix_fmt,
            "video.is_depth_map": False,
            "video.fps": int(fps),
            "video.channels": 3,
            "has_audio": False,
            "video.g": self.gop,
            "video.crf": self.quality,
        }
        if self.codec == "libsvtav1":
            info["video.preset"] = SVTAV1_PRESET
        info["is_depth_map"] = False
        return info

    def check_available(self) -> None:
        """Fail with one line when the installed PyAV cannot encode this codec."""
        av = require("av")
        try:
            av.codec.Codec(ENCODERS[self.codec], "w")
        except Exception:  # unknown codec: the error class differs across PyAV versions
            other = next(c for c in ENCODERS if c != self.codec)
            raise UserError(
                f"this PyAV build has no '{ENCODERS[self.codec]}' encoder; use --vcodec "
                f"{other}, or install the PyAV wheel from PyPI: pip install --force-reinstall av"
            ) from None


class CameraVideo:
    """The rolling mp4 files of one camera (see the module docstring).

    Args:
        root: dataset folder.
        key: the video feature key, ``observation.images.<camera>``.
        template: path template of video files (``VIDEO_PATH``).
        settings: encoding.
        fps: frames per second (whole number).
        height, width: frame size.
        max_file_mb: size at which the next episode starts a new file.
        chunks_size: files per chunk folder.
    """

    def __init__(
        self,
        root: Path,
        key: str,
        template: str,
        settings: VideoSettings,
        fps: int,
        height: int,
        width: int,
        max_file_mb: float,
        chunks_size: int,
    ) -> None:
        self._av = require("av")
        os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1 prints its banner otherwise
        self.root, self.key, self.template = root, key, template
        self.settings, self.fps = settings, int(fps)
        self.height, self.width = int(height), int(width)
        self.max_bytes = max_file_mb * 1024 * 1024
        self.chunks_size = chunks_size
        self.index: FileIndex | None = None
        self._path: Path | None = None
        self._container: Any = None
        self._stream: Any = None
        self._frames_in_file = 0
        self._episode_start = 0

    def begin_episode(self) -> tuple[FileIndex, float]:
        """Start an episode: returns its file and ``from_timestamp`` (s) in that file."""
        if self._container is not None and _size(self._path) >= self.max_bytes:
            self._close_file()
            self.index = self.index.next(self.chunks_size)
        if self._container is None:
            self.index = FileIndex() if self.index is None else self.index
            self._open_file()
        self._episode_start = self._frames_in_file
        return self.index, self._episode_start / self.fps

    @_keeps_scheduling
    def write(self, frames: np.ndarray) -> None:
        """Encode uint8 frames ``(n, H, W, 3)`` of the current episode."""
        av = self._av
        for image in frames:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            frame.pts = self._frames_in_file
            self._container.mux(self._stream.encode(frame))
            self._frames_in_file += 1

    def end_episode(self) -> float:
        """Finish the episode: returns its ``to_timestamp`` (s)."""
        return self._frames_in_file / self.fps

    def close(self) -> None:
        """Flush and close the current file (idempotent)."""
        if self._container is not None:
            self._close_file()

    @_keeps_scheduling
    def abort(self) -> None:
        """Close without caring for the file's content (on errors)."""
        if self._container is not None:
            try:
                if self._stream is not None:
                    self._stream.encode(None)  # end the stream: encoders complain otherwise
                self._container.close()
            except Exception:  # the folder is deleted anyway
                pass
            self._container = None

    @_keeps_scheduling
    def _open_file(self) -> None:
        self._path = self.root / self.index.path(self.template, video_key=self.key)
        self._path.parent.mkdir(parents=True, exist_ok=True)
        self._container = self._av.open(
            str(self._path), "w", format="mp4", options={"movflags": "+faststart"}
        )
        try:
            stream = self._container.add_stream(
                ENCODERS[self.settings.codec],
                rate=Fraction(self.fps, 1),
                options=self.settings.options(),
            )
            stream.width, stream.height = self.width, self.height
            stream.pix_fmt = self.settings.pix_fmt
            stream.codec_context.time_base = Fraction(1, self.fps)
            stream.codec_context.open()
        except Exception as exc:
            self._stream = None
            self.abort()
            raise UserError(
                f"cannot encode {self.width}x{self.height} {self.settings.pix_fmt} video with "
                f"{ENCODERS[self.settings.codec]} ({' '.join(str(exc).split())[:120]}); "
                "yuv420p H.264 needs even image sizes: try --vcodec h264 --pix_fmt yuv444p "
                "or --vcodec libsvtav1"
            ) from None
        self._stream = stream
        self._frames_in_file = 0

    @_keeps_scheduling
    def _close_file(self) -> None:
        self._container.mux(self._stream.encode(None))
        self._container.close()
        self._container = self._stream = None


def _size(path: Path) -> int:
    """Bytes written so far (the file appears with the first encoded packet)."""
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0
