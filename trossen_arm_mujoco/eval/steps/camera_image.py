"""A camera's whole frame made into the image a checkpoint was trained on, inside the
checkpoint's preprocessor.

A policy trained on ``record --crop`` episodes saw a rectangle of the camera's 480x640 frame
at a small size; this step cuts and scales any runner's whole frame the same way
(``sim.camera_crop.crop_frame``, on 8-bit pixels). A frame already at the trained size passes;
any other size of the 4:3 frame is taken as the whole frame; another shape is a ``ValueError``.

Docs: docs/cli/prepare.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from lerobot.processor import ProcessorStepRegistry
from lerobot.processor.pipeline import ObservationProcessorStep

from trossen_arm_mujoco.eval import step_names
from trossen_arm_mujoco.robot.lerobot_keys import image_key
from trossen_arm_mujoco.sim.camera_crop import FRAME, CameraCrop, crop_frame

__all__ = ["REGISTRY_NAME", "CameraImageStep"]

#: Name of the step in LeRobot's processor registry (and in ``policy_preprocessor.json``).
REGISTRY_NAME = step_names.IMAGE
_ASPECT_TOLERANCE = 0.01  # relative: a frame within 1 % of 4:3 is the whole frame


@ProcessorStepRegistry.register(REGISTRY_NAME)
@dataclass
class CameraImageStep(ObservationProcessorStep):
    """Each ``observation.images.<camera>`` as the checkpoint was trained on it.

    Args:
        cameras: per camera name, ``{"size": [height, width], "crop": [top, left, height,
            width]}``: the trained images' size (pixels) and the rectangle of the 480x640
            frame they showed (empty or absent: the whole frame).

    Images are LeRobot's: float (B, 3, H, W) or (3, H, W) in [0, 1], on any device; a camera
    the observation lacks is left to the steps that read it.
    """

    cameras: dict[str, dict[str, list[int]]] = field(default_factory=dict)

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        out = observation
        for camera, spec in self.cameras.items():
            key = image_key(camera)
            if out.get(key) is not None:
                made = _as_trained(key, torch.as_tensor(out[key]), camera, spec)
                if made is not None:
                    out = dict(out) if out is observation else out
                    out[key] = made
        return out

    def get_config(self) -> dict[str, Any]:
        return {
            "cameras": {
                c: {
                    "size": [int(v) for v in s["size"]],
                    "crop": [int(v) for v in s.get("crop") or []],
                }
                for c, s in self.cameras.items()
            }
        }

    def transform_features(self, features):
        return features


def _as_trained(key: str, image: Any, camera: str, spec: dict[str, list[int]]) -> Any:
    """``image`` cut and scaled to the trained images (None: it is at their size already)."""
    size = [int(v) for v in spec["size"]]
    h, w = int(image.shape[-2]), int(image.shape[-1])
    if [h, w] == size:
        return None
    if abs(w * FRAME[0] / (h * FRAME[1]) - 1.0) > _ASPECT_TOLERANCE:
        raise ValueError(
            f"{key} is {h}x{w}; the checkpoint takes the camera's whole 4:3 "
            f"frame (480x640) or its trained {size[0]}x{size[1]} images"
        )
    crop = CameraCrop(camera, *map(int, spec["crop"])) if spec.get("crop") else None
    batch = image.reshape(-1, *image.shape[-3:])
    pixels = (batch.detach().float().clamp(0, 1) * 255).round().to(torch.uint8)
    pixels = pixels.permute(0, 2, 3, 1).cpu().numpy()
    made = np.stack([crop_frame(p, crop, size) for p in pixels])
    out = torch.from_numpy(made).permute(0, 3, 1, 2).to(image.device)
    out = out.to(image.dtype if image.is_floating_point() else torch.float32) / 255.0
    return out.reshape(*image.shape[:-2], *out.shape[-2:])
