"""The recipes of ``trossen-mujoco train`` (``--recipe``) and the checks of their camera
settings.

A recipe is a set of flag defaults; any flag given on the command line still wins over it
(``--recipe camera --steps 9000``). ``state``: the command's own defaults (the 14 joint
values plus the object poses, 50 fps); ``camera``: the 14 joint values and ``cam_high``'s
crop at 60x80, 30 fps, ACT with ResNet-18 from scratch; ``camera_pose``: the same
observation, a pose encoder trained once finds the objects; ``camera_pose_robust``:
``camera_pose`` on randomized scenes. The camera settings are checked before anything runs,
one line each. Plain Python at import (the train phase may run without the simulator).

Docs: docs/cli/train.md, docs/train-eval.md; measured: docs/benchmarks.md; details:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

from typing import Any

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS

__all__ = [
    "BACKBONE_RATE",
    "CROPPED",
    "ENCODER_STRIDE",
    "POSE_ENCODER_MIN",
    "RECIPES",
    "camera_settings_error",
    "task_camera_facts",
    "task_cameras",
]

#: ResNet-18's output stride: one feature cell per 32x32 pixels of the input.
ENCODER_STRIDE = 32
#: The pose encoder's smallest image: its keypoint maps are at half the image's size, so 16
#: pixels leave 8 positions each way to locate an object among.
POSE_ENCODER_MIN = 16
#: The camera recipe's backbone rate flag (ResNet-18 from scratch learns at the policy's rate).
BACKBONE_RATE = "--policy.optimizer_lr_backbone=1e-4"

_CAMERA_DATA: dict[str, Any] = {
    "episodes": 200,
    "inject_noise": True,
    "cam_names": "cam_high",
    "image_size": "60x80",
    "fps": 30,
}

RECIPES: dict[str, dict[str, Any]] = {
    "state": {},
    "camera": {**_CAMERA_DATA, "no_env_state": True, "steps": 4500, "train_arg": [BACKBONE_RATE]},
    "camera_pose": {**_CAMERA_DATA, "pose_encoder": True, "steps": 7000},
    "camera_pose_robust": {
        **_CAMERA_DATA,
        "pose_encoder": True,
        "randomize": True,
        "augment": True,
        "steps": 7000,
    },
}

#: The recipes that look at a crop of ``cam_high`` around the task's objects.
CROPPED = ("camera", "camera_pose", "camera_pose_robust")


def task_camera_facts(recipe: str, task: str) -> tuple[str | None, int, str | None]:
    """The task's ``camera_crop`` and ``pose_static_frames`` (its ``TaskEntry``), and why a
    cropped recipe cannot run on it, in one line (None: it can). Where the simulator is not
    installed (a train-only machine) neither is needed: (None, 0, None)."""
    try:
        from trossen_arm_mujoco.errors import UserError
        from trossen_arm_mujoco.tasks.registry import load
    except ImportError:
        return None, 0, None
    try:
        entry = load(task)
    except UserError as exc:
        crop, static, why = None, 0, str(exc)
    else:
        crop, static = entry.camera_crop or None, entry.pose_static_frames
        why = f"its TaskEntry declares no camera_crop ({entry.package})"
    if recipe in CROPPED and crop is None:
        return (
            None,
            static,
            f"--recipe {recipe} knows no crop of cam_high for task {task!r} ({why}); give "
            "--crop cam_high:TOP,LEFT,HEIGHT,WIDTH around the task's objects, or declare "
            "TaskEntry(camera_crop=...)",
        )
    return crop, static, None


def task_cameras(task: str) -> tuple[str, ...]:
    """The cameras of ``task``'s scene (its sampler's ``cameras``: the kit's four, the Mobile
    AI's three, a single arm's ``overview`` and ``cam``); the kit's where the simulator is not
    installed or the task is unknown (the record phase then says so)."""
    try:
        from trossen_arm_mujoco.errors import UserError
        from trossen_arm_mujoco.tasks.registry import load
    except ImportError:
        return STATIONARY_CAMERAS
    try:
        cameras = tuple(load(task).sampler_class().cameras)
    except (UserError, ImportError, AttributeError):
        return STATIONARY_CAMERAS
    return cameras or STATIONARY_CAMERAS


def _camera_frame() -> tuple[int, int] | None:
    """The cameras' full frame (height, width), or None where the simulator is absent."""
    try:
        from trossen_arm_mujoco.sim.camera_crop import FRAME
    except ImportError:  # a train-only machine: the crop was checked where it was recorded
        return None
    return FRAME


def _crop_error(crop: str, names: list[str], cam_names: str) -> str | None:
    """What is wrong with ``--crop`` (``CAMERA:TOP,LEFT,HEIGHT,WIDTH``), or None."""
    camera, _, rest = crop.partition(":")
    try:
        top, left, height, width = (int(v) for v in rest.split(","))
    except ValueError:
        return (
            "--crop must be CAMERA:TOP,LEFT,HEIGHT,WIDTH in pixels of the camera's full "
            f"frame, e.g. cam_high:217,243,150,200; got '{crop}'"
        )
    if camera not in names:
        return (
            f"--crop {crop}: camera {camera!r} is not observed; add it to --cam_names ({cam_names})"
        )
    frame = _camera_frame()
    if frame is None:
        return None
    rows, cols = frame
    if min(top, left) < 0 or min(height, width) < 1 or top + height > rows or left + width > cols:
        return (
            f"--crop {crop} is outside the camera's {rows}x{cols} frame (top, left >= 0; "
            f"top + height <= {rows}; left + width <= {cols})"
        )
    return None


def camera_settings_error(
    cam_names: str,
    image_size: str,
    crop: str | None,
    pose_encoder: bool = False,
    cameras: tuple[str, ...] = STATIONARY_CAMERAS,
) -> str | None:
    """What is wrong with these camera settings, in one line (None: nothing).

    ``cam_names``: comma-separated camera names or ``none``; ``image_size``: ``HxW`` pixels;
    ``crop``: ``CAMERA:TOP,LEFT,HEIGHT,WIDTH`` or None. With ``pose_encoder`` the images feed
    the pose encoder, whose smallest image is :data:`POSE_ENCODER_MIN` (ResNet-18's is
    :data:`ENCODER_STRIDE`).

    Args:
        cam_names: comma-separated camera names or ``none``.
        image_size: ``HxW`` pixels.
        crop: ``CAMERA:TOP,LEFT,HEIGHT,WIDTH`` (pixels of the 480x640 frame) or None.
        pose_encoder: the images feed the pose encoder (its smallest image:
            :data:`POSE_ENCODER_MIN`).
        cameras: the task's cameras (:func:`task_cameras`; default the kit's four).
    """
    names = [n.strip() for n in cam_names.split(",") if n.strip()]
    if names == ["none"]:
        names = []
    unknown = [n for n in names if n not in cameras]
    if unknown:
        return (
            f"--cam_names {','.join(unknown)}: the task's scene has no such camera; choose "
            f"from {', '.join(cameras)} (or none)"
        )
    if names:
        try:
            height, width = (int(v) for v in image_size.lower().split("x"))
        except ValueError:
            return f"--image_size must be HEIGHTxWIDTH in pixels, e.g. 60x80; got '{image_size}'"
        least = POSE_ENCODER_MIN if pose_encoder else ENCODER_STRIDE
        if min(height, width) < least:
            what = (
                "the pose encoder resolves: its keypoint maps are at half the image's size"
                if pose_encoder
                else f"the image encoder resolves: ResNet-18 sees one feature per "
                f"{ENCODER_STRIDE}x{ENCODER_STRIDE} pixels"
            )
            return (
                f"--image_size {image_size} is below what {what}, so give at least {least} "
                "pixels each way (e.g. 60x80)"
            )
    return _crop_error(crop, names, cam_names) if crop else None
