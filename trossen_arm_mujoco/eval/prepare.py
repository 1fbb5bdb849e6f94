"""Make a LeRobot checkpoint trained on this project's export deployable by any runner.

``trossen-mujoco prepare CHECKPOINT`` puts in the checkpoint's saved processors every step a
runner needs (the step classes: ``eval.steps``): the image step (``trossen_camera_image``)
when its cameras were cropped or resized, the pose encoder (``trossen_camera_pose``) when it
was trained on a ``train.pose_dataset`` dataset, and always the controller's limits. What it
was trained with comes from ``export.dataset_settings.checkpoint_settings``. Preparing twice
leaves the checkpoint as once; plain JSON (LeRobot is needed to run the steps, not to add).

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import camera_pose_step, controller_limits_step, step_names
from trossen_arm_mujoco.eval.processor_files import (
    PREPROCESSOR_FILE,
    SavedProcessors,
    place_step,
    read_json,
)
from trossen_arm_mujoco.export.dataset_settings import DatasetSettings, checkpoint_settings
from trossen_arm_mujoco.sim.camera_crop import FRAME
from trossen_arm_mujoco.train.pose_files import ENCODER_FILE

__all__ = [
    "ENCODER_FILE",
    "IMAGE_STEP",
    "carries_images",
    "dataset_encoder",
    "image_step",
    "prepare_checkpoint",
]

#: Registry name of the image step (``eval.steps.camera_image``).
IMAGE_STEP = step_names.IMAGE


def image_step(settings: DatasetSettings | None) -> dict[str, Any] | None:
    """The saved image step for a checkpoint trained with ``settings`` (None: its images
    are whole 480x640 frames, or it has no cameras, or no settings)."""
    if settings is None or not settings.cameras.names:
        return None
    cams = settings.cameras
    cameras = {}
    for name in cams.names:
        crop = cams.crop_of(name)
        if crop is None and tuple(cams.size) == FRAME:
            continue
        box = [] if crop is None else [crop.top, crop.left, crop.height, crop.width]
        cameras[name] = {"size": [int(v) for v in cams.size], "crop": box}
    if not cameras:
        return None
    return {"registry_name": IMAGE_STEP, "config": {"cameras": cameras}}


def carries_images(policy: str | Path) -> bool:
    """Whether ``policy`` is a checkpoint folder whose preprocessor cuts and scales its
    cameras' whole frames itself (the image step): runners then hand it whole frames."""
    from trossen_arm_mujoco.eval.lerobot_policy import checkpoint_dir

    try:
        steps = read_json(checkpoint_dir(policy) / PREPROCESSOR_FILE).get("steps", [])
        return any(s.get("registry_name") == IMAGE_STEP for s in steps)
    except (UserError, OSError, ValueError, AttributeError, TypeError):
        return False


def dataset_encoder(folder: str | Path) -> Path | None:
    """The pose encoder of the dataset the checkpoint in ``folder`` was trained on (its
    ``train_config.json``'s dataset root), or None."""
    try:
        config = read_json(Path(folder) / "train_config.json")
        root = (config.get("dataset") or {}).get("root")
    except (OSError, ValueError, AttributeError):
        return None
    path = Path(root).expanduser() / ENCODER_FILE if root else None
    return path if path is not None and path.is_file() else None


def _steps_by_name(procs: SavedProcessors) -> dict[str, Any]:
    steps = procs.pre["steps"] + (procs.post or {}).get("steps", [])
    return {str(st.get("registry_name", st.get("class"))): st for st in steps}


def prepare_checkpoint(
    folder: str | Path, encoder: str | Path | None = None, camera: str | None = None
) -> list[str]:
    """Add (or bring up to date) every step the checkpoint in ``folder`` needs, in both
    processor files or neither; returns the names of the steps added or changed (empty: it
    was prepared already). The files are checked before anything is edited; a damaged one,
    or a folder that cannot be written, is one ``UserError`` and leaves the checkpoint as it
    was.

    Args:
        folder: the checkpoint folder (the one holding ``config.json``).
        encoder: a pose encoder to put in (default: the training dataset's, if any).
        camera: the camera the encoder reads (default: the checkpoint's pose step's, else
            its first camera).
    """
    folder = Path(folder)
    size = controller_limits_step.action_size(folder)
    procs = SavedProcessors.load(folder)
    settings, _ = checkpoint_settings(folder)
    before = _steps_by_name(procs)
    copied = False
    encoder = Path(encoder) if encoder is not None else dataset_encoder(folder)
    if encoder is not None:
        pose_steps = [
            st
            for st in procs.pre["steps"]
            if st.get("registry_name") == camera_pose_step.REGISTRY_NAME
        ]
        name = camera or (pose_steps[0].get("config", {}).get("camera") if pose_steps else None)
        if name is None and settings is not None and settings.cameras.names:
            name = settings.cameras.names[0]
        if name is None:
            raise UserError(
                f"{folder}: which camera does the pose encoder read? its settings "
                "name none; give --camera"
            )
        copied = camera_pose_step.copy_encoder(folder, encoder)
        camera_pose_step.add_pose(procs, name)
    step = image_step(settings)
    if step is not None:
        names = [st.get("registry_name") for st in procs.pre["steps"]]
        pose = camera_pose_step.REGISTRY_NAME
        anchor = pose if pose in names else "normalizer_processor"
        place_step(procs.pre["steps"], IMAGE_STEP, step, before=anchor)
    fps = None if settings is None else float(settings.fps)
    controller_limits_step.add_limits(
        procs, size, fps, None if settings is None else settings.layout
    )
    procs.save()
    after = _steps_by_name(procs)
    changed = [
        n
        for n in (camera_pose_step.REGISTRY_NAME, IMAGE_STEP, controller_limits_step.REGISTRY_NAME)
        if after.get(n) != before.get(n)
    ]
    if copied and camera_pose_step.REGISTRY_NAME not in changed:
        changed.insert(0, camera_pose_step.REGISTRY_NAME)
    if controller_limits_step.REGISTRY_NAME not in changed and after.get(
        controller_limits_step.MEASURED_NAME
    ) != before.get(controller_limits_step.MEASURED_NAME):
        changed.append(controller_limits_step.REGISTRY_NAME)
    return changed
