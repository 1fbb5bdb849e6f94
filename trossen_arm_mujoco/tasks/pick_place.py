"""Pick and place: grasp the cube and bring it to a goal on the table or in the air.

Config: ``config/pick_place.yaml`` (cube_low/high (x, y m), goal_low/high (x, y, z m),
air_goal_probability, lift_bonus, lift_height, ...). Achieved goal = cube centre, desired
goal = goal (world frame, m). Observations are those of ``push``.

Docs: docs/gym/WXAIPickPlace-v0.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.config_key import number
from trossen_arm_mujoco.tasks.push import (
    PUSH_KEYS,
    PUSH_REQUIRED,
    RECORD_EPISODE_LEN,
    PushSampler,
    PushTask,
    cube_rest_z,
)
from trossen_arm_mujoco.tasks.sampler import uniform
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

__all__ = ["TASKS", "PickPlaceSampler", "PickPlaceTask"]


class PickPlaceTask(PushTask):
    """Bring the cube's centre within ``success_tolerance`` of a 3-D goal (m).

    Args:
        scene: the task's scene.
        config: the task's checked config.
        goal: the goal (3,) world frame (m); None: sampled at reset.
    """

    name: ClassVar[str] = "pick_place"

    def __init__(self, scene: Scene, config: Mapping[str, Any], goal: Any = None):
        super().__init__(scene, config, goal)
        rest = cube_rest_z(scene, float(self.config["table_height"]))
        #: cube centre height (m) from which it counts as lifted
        self.lifted_z = rest + float(self.config["lift_height"])
        self.lift_bonus = float(self.config["lift_bonus"])

    def lifted(self) -> bool:
        """The cube is ``lift_height`` (m) or more above its resting height."""
        return bool(self.observed.read("cube_pos")[2] >= self.lifted_z)

    def reward_at(self, dist: float) -> float:
        """Push's shaped reward + lift_bonus while the cube is lifted."""
        return super().reward_at(dist) + self.lift_bonus * self.lifted()

    def info_at(self, dist: float) -> dict[str, Any]:
        """Push's diagnostics and ``lifted``."""
        info = super().info_at(dist)
        info["lifted"] = self.lifted()
        return info

    def get_task_description(self) -> str:
        """The episode's goal position in words (m, world frame)."""
        x, y, z = self.goal
        return f"pick up the red cube and place it at ({x:.3f}, {y:.3f}, {z:.3f}) m"


class PickPlaceSampler(PushSampler):
    """Cube as in push; goal (x, y) uniform, z uniform up to goal_high[2] with probability
    ``air_goal_probability``, otherwise resting on the table."""

    task_cls = PickPlaceTask

    def sample_goal(self, rng: np.random.Generator, cube: np.ndarray) -> np.ndarray | None:
        goal = super().sample_goal(rng, cube)
        if goal is None:
            return None
        low, high = self.config["goal_low"], self.config["goal_high"]
        in_air = rng.random() < float(self.config["air_goal_probability"])
        z_air = uniform(rng, max(cube[2], low[2]), max(cube[2], high[2]))
        goal[2] = z_air if in_air else cube[2]
        return goal


#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "pick_place",
        PickPlaceTask,
        PickPlaceSampler,
        "pick_place",
        "wxai: bring a cube to a goal on the table or in the air",
        policy="trossen_arm_mujoco.policies.pick_place:PickPlacePolicy",
        record=record_defaults(RECORD_EPISODE_LEN, cam_names=PushSampler.cameras),
        gym_ids={
            "TrossenMujoco/WXAIPickPlace-v0": "env",
            "TrossenMujoco/WXAIPickPlaceGoal-v0": "goal",
        },
        keys={
            **PUSH_KEYS,
            "air_goal_probability": number(0.0, 1.0),
            "lift_bonus": number(0.0, unit=""),
            "lift_height": number(0.0, 1.0, "m"),
        },
        required=(*PUSH_REQUIRED, "air_goal_probability", "lift_bonus", "lift_height"),
    ),
)
