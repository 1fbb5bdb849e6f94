"""A camera that shows one rectangle of its full 480x640 frame: a crop of the workspace.

A crop is given in pixels of the camera's full frame (``FRAME``, 480x640, the size its
``fovy`` describes): ``CameraCrop("cam_high", top=217, left=243, height=150, width=200)``
shows rows 217..366 and columns 243..442. It is applied to the compiled model as the camera's
intrinsics (``cam_sensorsize``, ``cam_intrinsic``), so any renderer draws the rectangle
straight at the image size asked for. A policy trained on cropped images is deployed by
cropping the real camera's full frame the same way (:func:`crop_frame`, as ``eval --backend
wire`` does). Text form (``--crop``): ``CAMERA:TOP,LEFT,HEIGHT,WIDTH``.

Docs: docs/cli/record.md (``--crop``); why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from PIL import Image

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id

__all__ = [
    "FRAME",
    "CameraCrop",
    "apply_crops",
    "check_observed",
    "crop_frame",
    "crop_texts",
    "parse_crop",
    "parse_crops",
]

#: (height, width) of the full frame a crop is given in, pixels (the cameras' 4:3 image).
FRAME: tuple[int, int] = (480, 640)
_FORMAT = (
    "CAMERA:TOP,LEFT,HEIGHT,WIDTH in pixels of the 480x640 frame, e.g. cam_high:217,243,150,200"
)


@dataclass(frozen=True)
class CameraCrop:
    """The rectangle of ``camera``'s full 480x640 frame it shows (pixels; rows from the
    top, columns from the left)."""

    camera: str
    top: int
    left: int
    height: int
    width: int

    def __post_init__(self) -> None:
        if not isinstance(self.camera, str) or not self.camera:
            raise UserError(f"a crop needs a camera name, got {self.camera!r}")
        for name in ("top", "left", "height", "width"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise UserError(f"crop {name} must be a whole number of pixels, got {value!r}")
        if self.top < 0 or self.left < 0 or self.height < 1 or self.width < 1:
            raise UserError(f"--crop {self.text()} must have top, left >= 0 and a positive size")
        if self.top + self.height > FRAME[0] or self.left + self.width > FRAME[1]:
            raise UserError(
                f"--crop {self.text()} reaches past the {FRAME[0]}x{FRAME[1]} frame "
                "(top + height <= 480, left + width <= 640)"
            )

    def text(self) -> str:
        """The ``--crop`` text of this crop."""
        return f"{self.camera}:{self.top},{self.left},{self.height},{self.width}"


def parse_crop(text: str) -> CameraCrop:
    """A ``CameraCrop`` from ``CAMERA:TOP,LEFT,HEIGHT,WIDTH``; a one-line UserError else."""
    camera, sep, rest = str(text).partition(":")
    parts = rest.split(",")
    if not sep or len(parts) != 4:
        raise UserError(f"--crop must look like {_FORMAT}; got '{text}'")
    try:
        top, left, height, width = (int(p) for p in parts)
    except ValueError:
        raise UserError(f"--crop must look like {_FORMAT}; got '{text}'") from None
    return CameraCrop(camera.strip(), top, left, height, width)


def parse_crops(texts: str | Sequence[str] | None) -> tuple[CameraCrop, ...]:
    """Crops of ``--crop`` values (one text, ``;`` between cameras, or several texts; None
    or empty: no crop); one crop per camera at most."""
    if not texts:
        return ()
    if isinstance(texts, str):
        texts = [t for t in texts.split(";") if t.strip()]
    crops = tuple(t if isinstance(t, CameraCrop) else parse_crop(t) for t in texts)
    cameras = [c.camera for c in crops]
    twice = sorted({c for c in cameras if cameras.count(c) > 1})
    if twice:
        raise UserError(f"one --crop per camera; {', '.join(twice)} has more than one")
    return crops


def apply_crops(model: mujoco.MjModel, crops: tuple[CameraCrop, ...]) -> None:
    """Make each cropped camera of ``model`` show its rectangle (sets its sensor size and
    intrinsics, in pixels of the full frame; its ``fovy`` gives the focal length). A camera
    the model lacks is a UserError listing the model's cameras."""
    for crop in crops:
        cid = lookup_id(model, "camera", crop.camera)
        if model.cam_sensorsize[cid].any():
            raise UserError(
                f"camera {crop.camera} already has a sensor size in the model; crop a camera "
                "described by fovy"
            )
        focal = (FRAME[0] / 2) / math.tan(math.radians(float(model.cam_fovy[cid])) / 2)
        model.cam_sensorsize[cid] = (crop.width, crop.height)
        # principal point: the rectangle's centre, measured from the frame's centre
        model.cam_intrinsic[cid] = (
            focal,
            focal,
            crop.left + crop.width / 2 - FRAME[1] / 2,
            crop.top + crop.height / 2 - FRAME[0] / 2,
        )


def crop_frame(image: np.ndarray, crop: CameraCrop | None, size: Sequence[int]) -> np.ndarray:
    """What a camera with ``crop`` shows at ``size``, made from a whole frame the way a
    deployed policy's images are: cut the rectangle out, then average it down (or up).

    Args:
        image: uint8 ``(H0, W0, 3)`` whole frame, any size of the 4:3 frame (the rectangle
            is scaled from 480x640 to it).
        crop: the rectangle; None: the whole frame, resized.
        size: (H, W) of the result (pixels).

    Returns:
        uint8 ``(H, W, 3)``; ``image`` itself when it is already at ``size`` with no crop.
    """
    h, w = int(size[0]), int(size[1])
    if crop is None and image.shape[:2] == (h, w):
        return image
    if crop is not None:
        sy, sx = image.shape[0] / FRAME[0], image.shape[1] / FRAME[1]
        top, left = round(crop.top * sy), round(crop.left * sx)
        image = image[
            top : top + max(1, round(crop.height * sy)),
            left : left + max(1, round(crop.width * sx)),
        ]
        if image.shape[:2] == (h, w):
            return np.ascontiguousarray(image)
    resized = Image.fromarray(np.ascontiguousarray(image)).resize((w, h), Image.Resampling.BOX)
    return np.asarray(resized, dtype=np.uint8)


def check_observed(crops: Sequence[CameraCrop], cameras: Sequence[str], what: str) -> None:
    """A one-line UserError when a crop names a camera that is not among ``cameras``.

    Args:
        crops: the crops.
        cameras: the cameras recorded or observed.
        what: which of the two ``cameras`` are, for the message.
    """
    for crop in crops:
        if crop.camera not in cameras:
            shown = ", ".join(cameras) or "none"
            raise UserError(
                f"--crop {crop.text()}: camera {crop.camera} is not {what} "
                f"({shown}); add it to --cam_names or leave the crop out"
            )


def crop_texts(crops: str | Sequence[str | CameraCrop] | None) -> str:
    """The ``--crop`` text of ``crops`` (``;`` between cameras; "" for none): how files
    store them (an episode's ``crops`` attribute)."""
    return ";".join(c.text() for c in parse_crops(crops))
