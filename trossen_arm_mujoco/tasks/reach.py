"""Reach: move the wxai tool frame (``ee_site``) to a target sampled in a box.

Config: ``config/reach.yaml`` (target_low/high, success_tolerance, distance_coef,
success_bonus, ...). Achieved goal = tool-frame position, desired goal = target (world, m).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from trossen_arm_mujoco.sim.env import MujocoEnv
from trossen_arm_mujoco.tasks.sampler import uniform
from trossen_arm_mujoco.tasks.single_arm import SingleArmSampler, SingleArmTask
from trossen_arm_mujoco.tasks.task import Bounds


class ReachTask(SingleArmTask):
    """Reach a target (m, world frame) with the tool frame."""

    name: ClassVar[str] = "reach"
    marker_body: ClassVar[str] = "target"

    def get_observation(self) -> dict[str, np.ndarray]:
        """Robot state only (see ``SingleArmTask.robot_observation``)."""
        return self.robot_observation()

    def observation_bounds(self) -> Bounds:
        return self.robot_bounds()

    def achieved_goal(self) -> np.ndarray:
        return self.ee_pos()

    _shortcuts = {"_object_parts": ("get_observation",), "_achieved_view": ("achieved_goal",)}

    def _object_parts(self) -> list[np.ndarray]:
        return []

    def _achieved_view(self) -> np.ndarray:
        return self._ee_view

    def reward_at(self, dist: float) -> float:
        """-distance_coef * |ee - target| (m) + success_bonus * success."""
        return -self.distance_coef * dist + self.success_bonus * (dist < self.tolerance)

    def get_task_description(self) -> str:
        x, y, z = self.goal
        return f"move the gripper tip to ({x:.3f}, {y:.3f}, {z:.3f}) m"


class ReachSampler(SingleArmSampler):
    """Random initial joints and a target uniform in [target_low, target_high] (m)."""

    task_cls = ReachTask

    def _sample_task(self, env: MujocoEnv) -> ReachTask:
        self.perturb_arm(self.rng)
        target = uniform(self.rng, self.config["target_low"], self.config["target_high"])
        return self.task_cls(env, self.config, goal=target)
