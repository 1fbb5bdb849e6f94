"""CameraSettings: what a policy's cameras observe, in one checked object.

Which cameras, the (H, W) of their images and the crops they show (``sim.camera_crop``) go
together from the command line to the renderer and the export: a command line parses
``--cam_names``, ``--image_size`` and ``--crop`` once (:meth:`CameraSettings.from_cli`, or
:func:`camera_flags` where a flag not given must stay "not given"), and the object travels
from there. Only files hold its text form (:meth:`CameraSettings.to_json` /
:meth:`CameraSettings.from_json`), e.g. ``{"cam_names": ["cam_high"], "image_size": [60,
80], "crops": ["cam_high:217,243,150,200"]}``; ``image_size`` is null without cameras;
``shadows`` and ``antialias`` are written only when false.

Docs: docs/cli/record.md, docs/datasets.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.camera_crop import FRAME, CameraCrop, check_observed, parse_crops
from trossen_arm_mujoco.sim.looks import SceneLooks

__all__ = [
    "DEFAULT_SIZE",
    "CameraSettings",
    "camera_flags",
    "parse_cameras",
    "parse_image_size",
]

#: (H, W) of the images when no size is given: the cameras' full frame.
DEFAULT_SIZE: tuple[int, int] = FRAME


def parse_image_size(text: str | Sequence[int]) -> tuple[int, int]:
    """``"HxW"`` (or a pair) -> (H, W) pixels, both positive; a one-line UserError else."""
    if isinstance(text, str):
        try:
            size = tuple(int(p) for p in text.lower().split("x"))
        except ValueError:
            size = ()
    else:
        try:
            size = tuple(int(v) for v in text)
        except (TypeError, ValueError):
            size = ()
    if len(size) != 2 or min(size) <= 0:
        raise UserError(
            f"image size must look like HxW with positive numbers (e.g. 480x640), got {text!r}"
        )
    return size  # type: ignore[return-value]


def parse_cameras(text: str | Sequence[str] | None) -> tuple[str, ...]:
    """A comma list (or sequence) of camera names; ``none`` or empty: no camera."""
    if text is None:
        return ()
    items = text.split(",") if isinstance(text, str) else list(text)
    names = tuple(str(c).strip() for c in items if str(c).strip())
    return () if names in (("none",), ("None",)) else names


@dataclass(frozen=True)
class CameraSettings:
    """What the observed cameras show.

    Attributes:
        names: observed cameras, in observation order (empty: state only).
        size: (H, W) of every observed camera's images, pixels.
        crops: the rectangle of its 480x640 frame each cropped camera shows
            (``sim.camera_crop.CameraCrop``, one per camera at most); default none.
        shadows, antialias: how the frames are drawn (``sim.looks.SceneLooks``); default
            both on.
    """

    names: tuple[str, ...] = ()
    size: tuple[int, int] = DEFAULT_SIZE
    crops: tuple[CameraCrop, ...] = ()
    shadows: bool = True
    antialias: bool = True

    def __post_init__(self) -> None:
        names = self.names
        if isinstance(names, str) or not isinstance(names, Sequence):
            raise UserError(
                f"camera names must be a list of names, got {names!r:.60} "
                "(e.g. ('cam_high', 'cam_low'))"
            )
        if not all(isinstance(c, str) and c.strip() for c in names):
            raise UserError(f"camera names must be non-empty strings, got {list(names)!r:.60}")
        twice = sorted({c for c in names if list(names).count(c) > 1})
        if twice:
            raise UserError(f"camera {', '.join(twice)} is listed twice; name each camera once")
        object.__setattr__(self, "names", tuple(names))
        object.__setattr__(self, "size", parse_image_size(self.size))
        crops = self.crops or ()
        if not all(isinstance(c, CameraCrop) for c in crops):
            raise UserError("crops must be CameraCrop values (sim.camera_crop.parse_crop)")
        object.__setattr__(self, "crops", parse_crops(tuple(crops)))  # one per camera
        check_observed(self.crops, self.names, "observed")
        for name in ("shadows", "antialias"):
            if not isinstance(getattr(self, name), bool):
                raise UserError(f"{name} must be true or false, got {getattr(self, name)!r:.40}")

    @classmethod
    def from_cli(
        cls,
        cam_names: str | Sequence[str] | None = None,
        image_size: str | Sequence[int] | None = None,
        crops: str | Sequence[str | CameraCrop] | None = None,
    ) -> CameraSettings:
        """The settings of the camera flags; a flag that is None or empty takes the default
        (no camera, 480x640, no crop).

        Args:
            cam_names: ``--cam_names``: a comma list or ``none``, or a sequence of names.
            image_size: ``--image_size``: ``HxW`` (pixels), or (H, W).
            crops: ``--crop``: ``CAMERA:TOP,LEFT,HEIGHT,WIDTH``, one text with ``;`` between
                cameras or several texts (or ``CameraCrop`` values).

        Raises:
            UserError: a bad value (one line).
        """
        flags = camera_flags(cam_names, image_size, crops)
        return cls(
            names=flags["cam_names"] or (),
            size=flags["image_size"] or DEFAULT_SIZE,
            crops=flags["crops"] or (),
        )

    def crop_of(self, camera: str) -> CameraCrop | None:
        """The crop ``camera`` shows, or None for its whole frame."""
        return next((c for c in self.crops if c.camera == camera), None)

    def scene_looks(self) -> SceneLooks:
        """The scene looks that draw these cameras' frames (crops, shadows, antialiasing)."""
        return SceneLooks(shadows=self.shadows, antialias=self.antialias, crops=self.crops)

    def crop_texts(self) -> tuple[str, ...]:
        """The ``--crop`` texts of the crops (for a command line or a message)."""
        return tuple(c.text() for c in self.crops)

    def to_json(self) -> dict[str, Any]:
        """The file form (see the module docstring): ``cam_names``, ``image_size`` (null
        without cameras), ``crops`` (their ``--crop`` texts), ``shadows`` and ``antialias``
        when false."""
        looks = {name: False for name in ("shadows", "antialias") if not getattr(self, name)}
        return {
            "cam_names": list(self.names),
            "image_size": list(self.size) if self.names else None,
            "crops": list(self.crop_texts()),
            **looks,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any], where: str) -> CameraSettings:
        """Parse :meth:`to_json`'s form (missing keys: the defaults); a one-line UserError
        naming ``where`` (the file) when it is not that form."""
        try:
            names = data.get("cam_names") or ()
            if isinstance(names, str):
                raise TypeError(f"cam_names must be a list, got {names!r}")
            size = data.get("image_size")
            return cls(
                names=tuple(str(c) for c in names),
                size=parse_image_size(size) if size else DEFAULT_SIZE,
                crops=parse_crops(list(data.get("crops") or ())),
                shadows=data.get("shadows", True),
                antialias=data.get("antialias", True),
            )
        except (AttributeError, TypeError, ValueError, UserError) as exc:
            raise UserError(f"{where}: unreadable camera settings ({exc})") from None


def camera_flags(
    cam_names: str | Sequence[str] | None,
    image_size: str | Sequence[int] | None,
    crops: str | Sequence[str | CameraCrop] | None,
) -> dict[str, Any]:
    """The camera flags of a command line, parsed, each None when not given. For a reader
    that fills the flags not given from elsewhere (a checkpoint's settings) before making
    the :class:`CameraSettings`.

    Args:
        cam_names: ``--cam_names`` as given (None: not given).
        image_size: ``--image_size`` as given.
        crops: ``--crop`` as given.

    Returns:
        ``cam_names`` (tuple of names; ``none``: the empty tuple), ``image_size`` ((H, W)
        pixels), ``crops`` (tuple of ``CameraCrop``).
    """
    return {
        "cam_names": parse_cameras(cam_names) if cam_names is not None else None,
        "image_size": parse_image_size(image_size) if image_size else None,
        "crops": parse_crops(crops) if crops else None,
    }
