"""The pose encoder as a preprocessor step: ``observation.environment_state`` from a camera.

The checkpoint's step (``eval.camera_pose_step.add_to_checkpoint`` puts it there) reads the
camera's image (``observation.images.<camera>``, float (B, 3, H, W) in [0, 1] at the trained
size: :mod:`.camera_image` runs before it) and writes the objects' poses the frozen encoder
of the step's state file estimates, replacing whatever the env gave.

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import torch
from lerobot.processor import ProcessorStepRegistry
from lerobot.processor.pipeline import ObservationProcessorStep

from trossen_arm_mujoco.eval.step_names import POSE as REGISTRY_NAME
from trossen_arm_mujoco.robot.lerobot_keys import ENV_STATE_KEY, image_key
from trossen_arm_mujoco.train.pose_encoder import encoder_from_state

__all__ = ["CameraPoseStep"]


@ProcessorStepRegistry.register(REGISTRY_NAME)
@dataclass
class CameraPoseStep(ObservationProcessorStep):
    """``observation.environment_state`` from ``camera``'s image, by the frozen encoder of
    the step's state file.

    Args:
        camera: the camera the encoder reads (``cam_high``).
    """

    camera: str = "cam_high"
    _net: Any = field(default=None, init=False, repr=False)

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        key = image_key(self.camera)
        image = observation.get(key)
        if image is None:
            raise ValueError(
                f"the checkpoint's pose encoder reads {key}, which this "
                f"observation lacks: serve the camera {self.camera}"
            )
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
        if self._net is None:
            return {}
        return {k: v.detach().cpu().contiguous() for k, v in self._net.state_dict().items()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self._net = encoder_from_state(state)

    def transform_features(self, features):
        return features
