"""Reach: move the wxai tool frame (``ee_site``) to a target sampled in a box.

Config: ``config/reach.yaml`` (target_low/high, success_tolerance, distance_coef,
success_bonus, ...). Achieved goal = tool-frame position, desired goal = target (world, m).

Docs: docs/gym/WXAIReach-v0.md.
"""

from __future__ import annotations

from typing import ClassVar

from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.config_key import region
from trossen_arm_mujoco.tasks.sampler import uniform
from trossen_arm_mujoco.tasks.single_arm import (
    SINGLE_ARM_KEYS,
    SINGLE_ARM_REQUIRED,
    SingleArmSampler,
    SingleArmTask,
)
from trossen_arm_mujoco.tasks.task_entry import TaskEntry

__all__ = ["TASKS", "ReachSampler", "ReachTask"]


class ReachTask(SingleArmTask):
    """Reach a target (m, world frame) with the tool frame."""

    name: ClassVar[str] = "reach"
    marker_body: ClassVar[str] = "target"
    #: the observation is the robot's parts (``SingleArmTask.robot_parts``); the tool frame
    #: is the achieved goal
    achieved_part: ClassVar[str] = "ee_pos"

    def reward_at(self, dist: float) -> float:
        """-distance_coef * |ee - target| (m) + success_bonus * success."""
        return -self.distance_coef * dist + self.success_bonus * (dist < self.tolerance)

    def get_task_description(self) -> str:
        """The episode's target of the tool in words (m, world frame)."""
        x, y, z = self.goal
        return f"move the gripper tip to ({x:.3f}, {y:.3f}, {z:.3f}) m"


class ReachSampler(SingleArmSampler):
    """Random initial joints and a target uniform in [target_low, target_high] (m)."""

    task_cls = ReachTask

    def _sample_task(self, scene: Scene) -> ReachTask:
        self.perturb_arm(self.rng)
        target = uniform(self.rng, self.config["target_low"], self.config["target_high"])
        return self.task_cls(scene, self.config, goal=target)


#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "reach",
        ReachTask,
        ReachSampler,
        "reach",
        "wxai: move the tool frame to a target",
        gym_ids={"TrossenMujoco/WXAIReach-v0": "env", "TrossenMujoco/WXAIReachGoal-v0": "goal"},
        keys={**SINGLE_ARM_KEYS, **region("target", 3)},
        required=(*SINGLE_ARM_REQUIRED, "target_low", "target_high"),
    ),
)
