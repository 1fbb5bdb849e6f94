"""The pose encoder as a step of a checkpoint's saved preprocessor: the policy then observes
the joints and one camera, and the objects' poses it was trained on come from that camera.

:func:`add_to_checkpoint` puts the frozen encoder of a ``train.pose_dataset`` dataset in the
checkpoint: a preprocessor step ``trossen_camera_pose`` (:data:`REGISTRY_NAME`) before the
normalizer, which reads ``observation.images.<camera>`` ((B, 3, H, W) in [0, 1]) and writes
``observation.environment_state``. Editing the JSON needs no LeRobot; running the step does::

    python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT ENCODER.safetensors CAMERA

Docs: docs/cli/prepare.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import filecmp
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import step_names
from trossen_arm_mujoco.eval.processor_files import (
    PREPROCESSOR_FILE,
    SavedProcessors,
    place_step,
    read_json,
)
from trossen_arm_mujoco.fileio import atomic_path

__all__ = [
    "REGISTRY_NAME",
    "STATE_FILE",
    "add_pose",
    "add_to_checkpoint",
    "camera_of",
    "copy_encoder",
    "register",
]

#: Name of the step in LeRobot's processor registry (and in ``policy_preprocessor.json``).
REGISTRY_NAME = step_names.POSE
#: The encoder's weights in the checkpoint folder (the step's ``state_file``).
STATE_FILE = "policy_preprocessor_trossen_camera_pose.safetensors"


def camera_of(folder: str | Path) -> str | None:
    """The camera a checkpoint's pose step reads, or None when it has no such step (read
    without LeRobot; a checkpoint without saved processors has none)."""
    try:
        steps = read_json(Path(folder) / PREPROCESSOR_FILE)
        for step in steps.get("steps", []):
            if step.get("registry_name") == REGISTRY_NAME:
                return str(step["config"]["camera"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    return None


def add_pose(procs: SavedProcessors, camera: str) -> None:
    """Put (or bring up to date) the pose step reading ``camera`` in ``procs``'s
    preprocessor (in memory), before the normalizer; its weights are :data:`STATE_FILE`."""
    step = {"registry_name": REGISTRY_NAME, "config": {"camera": camera}, "state_file": STATE_FILE}
    place_step(procs.pre["steps"], REGISTRY_NAME, step, before="normalizer_processor")


def copy_encoder(folder: str | Path, encoder: str | Path) -> bool:
    """The encoder saved at ``encoder`` as the checkpoint's :data:`STATE_FILE` (atomically);
    False when that very file is there already."""
    folder, encoder = Path(folder), Path(encoder)
    if not encoder.is_file():
        raise UserError(
            f"{encoder}: no pose encoder there; derive the dataset first "
            "(python -m trossen_arm_mujoco.train.pose_dataset)"
        )
    state = folder / STATE_FILE
    if state.is_file() and filecmp.cmp(encoder, state, shallow=False):
        return False
    try:
        with atomic_path(state) as tmp:
            shutil.copyfile(encoder, tmp)
    except OSError as exc:
        raise UserError(
            f"{state}: cannot write it ({exc.strerror or exc}); make the checkpoint folder writable"
        ) from None
    return True


def add_to_checkpoint(folder: str | Path, encoder: str | Path, camera: str) -> bool:
    """Put the encoder saved at ``encoder`` (``train.pose_encoder.save_encoder``) in the
    checkpoint ``folder``'s preprocessor, reading ``camera``; again replaces it. False when
    that very encoder and step were there already.

    Args:
        folder: the checkpoint folder (``.../pretrained_model``).
        encoder: the encoder's ``.safetensors`` file.
        camera: the camera whose image (``observation.images.<camera>``) the step reads.
    """
    procs = SavedProcessors.load(folder, post=False)
    copied = copy_encoder(folder, encoder)
    add_pose(procs, camera)
    return procs.save() or copied


def register() -> None:
    """Register the step with LeRobot's processor registry (needs LeRobot; importing
    ``eval.steps`` does it, once a process)."""
    import trossen_arm_mujoco.eval.steps  # noqa: F401


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT ENCODER CAMERA``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 3:
        print(
            "usage: python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT "
            "ENCODER.safetensors CAMERA",
            file=sys.stderr,
        )
        return 2
    try:
        add_to_checkpoint(*args)
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{args[0]}: the step {REGISTRY_NAME} reads {args[2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
