"""The single WidowX AI arm's tasks as eval sees them, without building anything: which
tasks are a single arm's (``is_arm_task``: sampler derived from
``tasks.single_arm.SingleArmSampler``), their 7-value layout (``widowxai``: ``joint_0`` ..
``joint_5`` rad, then the gripper's ``left_carriage_joint`` travel m) and their LeRobot
features (``arm_feature_spec``). The env itself is ``eval.arm_env.ArmPolicyEnv``.

Docs: docs/cli/eval.md.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.robot.lerobot_keys import (
    ACTION_KEY,
    ENV_STATE_KEY,
    STATE_KEY,
    VELOCITY_KEY,
    image_key,
)
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = [
    "ARM_LAYOUT",
    "ARM_LAYOUT_NAME",
    "ArmLayout",
    "arm_feature_spec",
    "arm_names",
    "arm_object_count",
    "is_arm_task",
]

#: The layout name of one arm's 7 values (the recordings' ``layout`` attribute).
ARM_LAYOUT_NAME = "widowxai"


class ArmLayout:
    """One WidowX AI arm's 7 values: ``joint_0`` .. ``joint_5`` (rad), then the gripper
    (``left_carriage_joint`` travel, m), as the single arm's recordings store them."""

    size: int = 7
    names: tuple[str, ...] = (*(f"joint_{i}" for i in range(6)), "left_carriage_joint")

    def from_vendor(self, values: np.ndarray) -> np.ndarray:
        """The 7 values as they are (the recordings are in this layout already)."""
        return np.asarray(values)


#: The single arm's layout.
ARM_LAYOUT = ArmLayout()


def is_arm_task(task: str) -> bool:
    """Whether ``task`` (a name or alias) is a single wxai arm's task
    (``tasks.registry.arm_names``)."""
    return registry.ALIASES.get(task, task) in registry.arm_names()


def arm_names() -> list[str]:
    """The single-arm tasks (``tasks.registry.arm_names``), sorted."""
    return registry.arm_names()


def arm_object_count(task: str) -> int:
    """How many free objects a single-arm task's scene holds (its sampler's ``objects()``,
    read without building the scene when the sampler allows; else from a built sampler)."""
    entry = registry.load(task)
    sampler_cls = entry.sampler_class()
    try:
        return len(sampler_cls.objects(sampler_cls.__new__(sampler_cls)))
    except Exception:  # objects() reads the sampler's state: build one
        sampler = registry.make_sampler(entry.name, SamplerSettings())
        try:
            return len(sampler.scene.objects)
        finally:
            sampler.close()


def arm_feature_spec(
    n_objects: int, cam_names: tuple[str, ...], image_size: tuple[int, int]
) -> dict[str, tuple[str, str, tuple[int, ...]]]:
    """What an ``ArmPolicyEnv`` with ``n_objects`` objects observes and takes, as LeRobot
    features (``eval.env.feature_spec``'s form: env key -> (LeRobot key, kind, shape)).

    Args:
        n_objects: the number of task objects (7 values each in ``environment_state``: xyz m, quat
            wxyz, world).
        cam_names: the observed cameras (images (H, W, 3) uint8).
        image_size: (H, W) of each image, pixels.
    """
    h, w = image_size
    spec: dict[str, tuple[str, str, tuple[int, ...]]] = {
        "action": (ACTION_KEY, "ACTION", (ARM_LAYOUT.size,)),
        "agent_pos": (STATE_KEY, "STATE", (ARM_LAYOUT.size,)),
        "velocity": (VELOCITY_KEY, "STATE", (ARM_LAYOUT.size,)),
        "environment_state": (ENV_STATE_KEY, "ENV", (7 * n_objects,)),
    }
    for cam in cam_names:
        key = image_key(cam)
        spec[key] = (key, "VISUAL", (h, w, 3))
    return spec
