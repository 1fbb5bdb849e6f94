"""Push: push a cube across the table onto a goal marked on the table.

Config: ``config/push.yaml`` (cube_low/high, goal_low/high (x, y m), min_goal_distance,
success_tolerance, reach_coef, distance_coef, success_bonus, ...). Achieved goal = cube
centre, desired goal = goal (world frame, m).

Docs: docs/gym/WXAIPush-v0.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.config_key import Key, number, region
from trossen_arm_mujoco.tasks.observation import Part
from trossen_arm_mujoco.tasks.sampler import uniform
from trossen_arm_mujoco.tasks.single_arm import (
    SINGLE_ARM_KEYS,
    SINGLE_ARM_REQUIRED,
    SingleArmSampler,
    SingleArmTask,
    goal_distance,
)
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

__all__ = [
    "TASKS",
    "CUBE",
    "MAX_GOAL_TRIES",
    "RECORD_EPISODE_LEN",
    "PushSampler",
    "PushTask",
    "cube_rest_z",
]

CUBE = ("cube", ("cube_joint", "cube"))
MAX_GOAL_TRIES = 100
#: Steps (0.02 s) of a recorded episode of push and of pick_place (``record``): their
#: scripted policies (``policies/push.py``, ``policies/pick_place.py``) need 300 and 320.
RECORD_EPISODE_LEN = 350


def cube_rest_z(scene: Scene, table_height: float) -> float:
    """Height (m) of the centre of the cube resting on the table."""
    cube = scene.objects["cube"]
    return float(table_height + scene.model.geom_size[cube.geom_id][2])


class PushTask(SingleArmTask):
    """Bring the cube's centre within ``success_tolerance`` of the goal (m).

    Args:
        scene: the task's scene.
        config: the task's checked config.
        goal: the goal on the table, (3,) world frame (m); None: sampled at reset.
    """

    name: ClassVar[str] = "push"
    marker_body: ClassVar[str] = "goal"
    #: the cube's centre is the achieved goal
    achieved_part: ClassVar[str] = "cube_pos"

    def __init__(self, scene: Scene, config: Mapping[str, Any], goal: Any = None):
        super().__init__(scene, config, goal)
        self.cube = scene.objects["cube"]
        self.max_obj_vel = float(self.config["max_object_velocity"])
        self.reach_coef = float(self.config["reach_coef"])

    def observation_parts(self) -> list[Part]:
        """The robot's parts, then ``cube_pos`` (3,) m, ``cube_quat`` (4,) wxyz, ``cube_vel``
        (6,) [m/s, rad/s] (live views of ``data``) and ``cube_rel`` (3,) m = cube_pos -
        ee_pos (computed)."""
        data = self.data
        ee, pose = self.arm.frame_position_view(data), self.cube.pose_view(data)
        cube_pos, span = pose[:3], self.ws_high - self.ws_low
        v = self.max_obj_vel
        return [
            *self.robot_parts(),
            Part("cube_pos", cube_pos, self.ws_low, self.ws_high),
            Part("cube_quat", pose[3:], -1.0, 1.0),
            Part("cube_vel", self.cube.velocity_view(data), -v, v),
            Part("cube_rel", lambda: cube_pos - ee, -span, span),
        ]

    def cube_pos(self) -> np.ndarray:
        """Cube centre, world frame (3,) m (a copy)."""
        return self.observed.read("cube_pos").copy()

    def reward_at(self, dist: float) -> float:
        """-reach_coef * |ee - cube| - distance_coef * |cube - goal| + success_bonus * success
        (``dist`` = |cube - goal|, m)."""
        observed = self.observed
        reach = goal_distance(observed.read("ee_pos"), observed.read("cube_pos"))
        return (
            -self.reach_coef * reach
            - self.distance_coef * dist
            + self.success_bonus * (dist < self.tolerance)
        )

    def get_task_description(self) -> str:
        """The episode's goal on the table in words (m, world frame)."""
        x, y, _ = self.goal
        return f"push the red cube to ({x:.3f}, {y:.3f}) m on the table"


class PushSampler(SingleArmSampler):
    """Cube uniform in [cube_low, cube_high] (x, y m) with a random yaw; goal uniform in
    [goal_low, goal_high], at least ``min_goal_distance`` from the cube."""

    task_cls = PushTask

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return dict([CUBE])

    def place_cube(self, rng: np.random.Generator) -> np.ndarray:
        """Put the cube at a random resting pose; returns its centre (3,) m."""
        xy = uniform(rng, self.config["cube_low"], self.config["cube_high"])
        yaw = uniform(rng, -np.pi, np.pi)
        z = cube_rest_z(self.scene, float(self.config["table_height"]))
        pose = [xy[0], xy[1], z, np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        self.scene.objects["cube"].set_pose(self.scene.data, pose)
        return np.array([xy[0], xy[1], z])

    def sample_goal(self, rng: np.random.Generator, cube: np.ndarray) -> np.ndarray | None:
        """Goal (3,) m on the table, away from the cube (rejection sampling, bounded tries);
        None when no try was far enough."""
        low, high = self.config["goal_low"], self.config["goal_high"]
        min_dist = float(self.config["min_goal_distance"])
        goal = cube.copy()
        for _ in range(MAX_GOAL_TRIES):
            goal[:2] = uniform(rng, low[:2], high[:2])
            if np.linalg.norm(goal[:2] - cube[:2]) >= min_dist:
                return goal
        return None

    def _sample_task(self, scene: Scene) -> PushTask | None:
        self.perturb_arm(self.rng)
        cube = self.place_cube(self.rng)
        goal = self.sample_goal(self.rng, cube)
        return None if goal is None else self.task_cls(scene, self.config, goal=goal)


#: Config keys of push (and pick_place, which adds its own): the cube's spawn region, the
#: goal region (2 values on the table, 3 with a height) and the goal's least distance.
PUSH_KEYS: dict[str, Key] = {
    **SINGLE_ARM_KEYS,
    **region("cube", 2),
    **region("goal", 2, 3),
    "min_goal_distance": number(0.0, 10.0, "m"),
}
PUSH_REQUIRED: tuple[str, ...] = (
    *SINGLE_ARM_REQUIRED,
    "cube_low",
    "cube_high",
    "goal_low",
    "goal_high",
    "min_goal_distance",
    "reach_coef",
    "max_object_velocity",
)

#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "push",
        PushTask,
        PushSampler,
        "push",
        "wxai: push a cube onto a goal on the table",
        policy="trossen_arm_mujoco.policies.push:PushPolicy",
        record=record_defaults(RECORD_EPISODE_LEN, cam_names=SingleArmSampler.cameras),
        gym_ids={"TrossenMujoco/WXAIPush-v0": "env", "TrossenMujoco/WXAIPushGoal-v0": "goal"},
        keys=PUSH_KEYS,
        required=PUSH_REQUIRED,
    ),
)
