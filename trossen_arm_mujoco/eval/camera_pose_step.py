"""The pose encoder as a step of a checkpoint's saved preprocessor: the policy then observes
the joints and one camera, and the objects' poses it was trained on come from that camera.

A policy trained on a dataset that ``train.pose_dataset`` derived (its
``observation.environment_state`` is the encoder's estimate from the camera, not the
simulation's exact poses) needs the same estimate at run time. :func:`add_to_checkpoint`
puts the frozen encoder in the checkpoint: a preprocessor step ``trossen_camera_pose``
(:data:`REGISTRY_NAME`), before the normalizer, that reads the camera's image
(``observation.images.<camera>``, (B, 3, H, W) in [0, 1], as LeRobot's
``preprocess_observation`` gives it) and writes ``observation.environment_state`` from it,
replacing whatever the env gave (the simulation offers the exact poses; they never reach
the policy). Its weights are the step's state file, so every runner of the checkpoint's
processors (``trossen-mujoco eval`` in-process and through the wire, LeRobot's tools where
the env plugin ``lerobot_env_trossen`` is installed) runs it.

Editing the JSON needs no LeRobot; running the step does::

    python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT ENCODER.safetensors CAMERA
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.processor_files import (
    PREPROCESSOR_FILE,
    place_step,
    read_json,
    write_json,
)
from trossen_arm_mujoco.fileio import atomic_path
from trossen_arm_mujoco.robot.lerobot_keys import ENV_STATE_KEY, image_key

__all__ = ["REGISTRY_NAME", "STATE_FILE", "add_to_checkpoint", "camera_of", "register"]

#: Name of the step in LeRobot's processor registry (and in ``policy_preprocessor.json``).
REGISTRY_NAME = "trossen_camera_pose"
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


def add_to_checkpoint(folder: str | Path, encoder: str | Path, camera: str) -> None:
    """Put the encoder saved at ``encoder`` (``train.pose_encoder.save_encoder``) in the
    checkpoint ``folder``'s preprocessor, reading ``camera``; again replaces it."""
    folder, encoder = Path(folder), Path(encoder)
    pre = folder / PREPROCESSOR_FILE
    try:
        pipeline = read_json(pre)
        steps: list[dict[str, Any]] = pipeline["steps"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise UserError(f"{folder}: not a LeRobot checkpoint with saved processors "
                        f"({exc})") from None  # fmt: skip
    if not encoder.is_file():
        raise UserError(f"{encoder}: no pose encoder there; derive the dataset first "
                        "(python -m trossen_arm_mujoco.train.pose_dataset)")  # fmt: skip
    with atomic_path(folder / STATE_FILE) as tmp:
        shutil.copyfile(encoder, tmp)
    step = {"registry_name": REGISTRY_NAME, "config": {"camera": camera}, "state_file": STATE_FILE}
    if place_step(steps, REGISTRY_NAME, step, before="normalizer_processor"):
        write_json(pre, pipeline)


def register() -> None:
    """Register the step with LeRobot's processor registry (needs LeRobot; twice is fine)."""
    from dataclasses import dataclass, field

    import torch
    from lerobot.processor import ProcessorStepRegistry
    from lerobot.processor.pipeline import ObservationProcessorStep

    from trossen_arm_mujoco.train.pose_encoder import encoder_from_state

    if REGISTRY_NAME in ProcessorStepRegistry.list():
        return

    @ProcessorStepRegistry.register(REGISTRY_NAME)
    @dataclass
    class CameraPoseStep(ObservationProcessorStep):
        """``observation.environment_state`` from the camera's image, by the frozen encoder
        of the step's state file (the env's own value, if any, is replaced)."""

        camera: str = "cam_high"
        _net: Any = field(default=None, init=False, repr=False)

        def observation(self, observation):
            key = image_key(self.camera)
            image = observation.get(key)
            if image is None:
                raise ValueError(f"the checkpoint's pose encoder reads {key}, which this "
                                 f"observation lacks: serve the camera {self.camera}")  # fmt: skip
            if self._net is None:
                raise ValueError("the pose step has no encoder weights (its state file)")
            image = torch.as_tensor(image)
            if image.ndim == 3:
                image = image.unsqueeze(0)
            net = self._net.to(image.device)
            with torch.inference_mode():
                pose = net(image.float())
            observation = dict(observation)
            observation[ENV_STATE_KEY] = pose.clone()
            return observation

        def get_config(self) -> dict[str, Any]:
            return {"camera": self.camera}

        def state_dict(self) -> dict[str, Any]:
            return (
                {}
                if self._net is None
                else {k: v.detach().cpu().contiguous() for k, v in self._net.state_dict().items()}
            )

        def load_state_dict(self, state: dict[str, Any]) -> None:
            self._net = encoder_from_state(state)

        def transform_features(self, features):
            return features


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT ENCODER CAMERA``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 3:
        print("usage: python -m trossen_arm_mujoco.eval.camera_pose_step CHECKPOINT "
              "ENCODER.safetensors CAMERA", file=sys.stderr)  # fmt: skip
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
