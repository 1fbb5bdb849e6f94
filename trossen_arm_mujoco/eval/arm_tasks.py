"""The single WidowX AI arm's tasks as eval sees them, without building anything: which
tasks are a single arm's (``is_arm_task``: sampler derived from
``tasks.single_arm.SingleArmSampler``), their 7-value layout (``widowxai``: ``joint_0`` ..
``joint_5`` rad, then the gripper's ``left_carriage_joint`` travel m) and their LeRobot
features (``arm_feature_spec``). The env itself is ``eval.arm_env.ArmPolicyEnv``.

Docs: docs/cli/eval.md.
"""

from __future__ import annotations

from trossen_arm_mujoco.data.schema import SINGLE_ARM_LAYOUT
from trossen_arm_mujoco.robot.layout import WIDOWXAI_LAYOUT
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
    "arm_feature_spec",
    "arm_goal_conditioned",
    "arm_names",
    "arm_object_count",
    "is_arm_task",
]

#: The layout name of one arm's 7 values (the recordings' ``layout`` attribute).
ARM_LAYOUT_NAME = SINGLE_ARM_LAYOUT
#: The single arm's layout: ``joint_0`` .. ``joint_5`` (rad), then the gripper
#: (``left_carriage_joint`` travel, m), as its recordings store them and Trossen's plugin
#: for one follower names them.
ARM_LAYOUT = WIDOWXAI_LAYOUT


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


def arm_goal_conditioned(task: str) -> bool:
    """Whether a single-arm task has a goal (its ``environment_state`` ends with it)."""
    return bool(getattr(registry.load(task).task_class(), "goal_conditioned", False))


def arm_feature_spec(
    n_objects: int, cam_names: tuple[str, ...], image_size: tuple[int, int], goal: bool = False
) -> dict[str, tuple[str, str, tuple[int, ...]]]:
    """What an ``ArmPolicyEnv`` with ``n_objects`` objects observes and takes, as LeRobot
    features (``eval.env.feature_spec``'s form: env key -> (LeRobot key, kind, shape)).

    Args:
        n_objects: the number of task objects (7 values each in ``environment_state``: xyz m, quat
            wxyz, world).
        cam_names: the observed cameras (images (H, W, 3) uint8).
        image_size: (H, W) of each image, pixels.
        goal: the task is goal-conditioned: ``environment_state`` ends with its goal (3 values,
            m, world), as ``export --sim_features`` writes it (``export.goal_state``).
    """
    h, w = image_size
    spec: dict[str, tuple[str, str, tuple[int, ...]]] = {
        "action": (ACTION_KEY, "ACTION", (ARM_LAYOUT.size,)),
        "agent_pos": (STATE_KEY, "STATE", (ARM_LAYOUT.size,)),
        "velocity": (VELOCITY_KEY, "STATE", (ARM_LAYOUT.size,)),
        "environment_state": (ENV_STATE_KEY, "ENV", (7 * n_objects + 3 * bool(goal),)),
    }
    for cam in cam_names:
        key = image_key(cam)
        spec[key] = (key, "VISUAL", (h, w, 3))
    return spec
