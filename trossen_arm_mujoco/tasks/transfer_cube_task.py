"""Transfer cube as a ``Task``/``TaskSampler`` pair (Stationary AI kit, joint actuators).

Scoring is ``tasks.transfer_cube.TransferCubeReward`` (sparse 0-4, success = 4) and the
cube spawns by ``tasks.transfer_cube.sample_cube_pose``: nothing is reimplemented here.
Config: ``config/transfer_cube.yaml``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.constants import STATIONARY_CAMERAS
from trossen_arm_mujoco.robot.configs import RobotConfig, stationary_ai_joint_config
from trossen_arm_mujoco.sim.env import MujocoEnv
from trossen_arm_mujoco.tasks.sampler import TaskSampler
from trossen_arm_mujoco.tasks.stationary import LAYOUT_GROUPS
from trossen_arm_mujoco.tasks.task import Bounds, Task
from trossen_arm_mujoco.tasks.transfer_cube import (
    MAX_REWARD,
    TransferCubeReward,
    sample_cube_pose,
)


class TransferTask(Task):
    """Hand the cube from the right gripper to the left one, lifted off the table."""

    name: ClassVar[str] = "transfer_cube"
    robot_name: ClassVar[str] = "stationary_ai"

    def __init__(self, env: MujocoEnv, config: Mapping[str, Any]):
        super().__init__(env, config)
        view = self.robot.view
        self.layout = view.qpos_indices(LAYOUT_GROUPS)
        self.layout_dofs = view.dof_indices(LAYOUT_GROUPS)
        ranges = np.concatenate([view.group(g).joint_range for g in LAYOUT_GROUPS])
        self.qpos_low, self.qpos_high = ranges[:, 0].copy(), ranges[:, 1].copy()
        self.max_qvel = float(self.config["max_joint_velocity"])
        self.max_obj_vel = float(self.config["max_object_velocity"])
        self.ws_low = np.asarray(self.config["workspace_low"], dtype=float)
        self.ws_high = np.asarray(self.config["workspace_high"], dtype=float)
        self.cube = env.objects["box"]
        self.reward_fn = TransferCubeReward(env.model)

    def get_observation(self) -> dict[str, np.ndarray]:
        """qpos (16,) and qvel (16,) in the kit layout (rad, m; rad/s, m/s), cube_pose (7,)
        [xyz m, quat wxyz], cube_vel (6,) [m/s, rad/s]."""
        return {
            "qpos": self.data.qpos[self.layout].copy(),
            "qvel": self.data.qvel[self.layout_dofs].copy(),
            "cube_pose": self.cube.get_pose(self.data),
            "cube_vel": self.cube.get_velocity(self.data),
        }

    def observation_bounds(self) -> Bounds:
        return {
            "qpos": (self.qpos_low.copy(), self.qpos_high.copy()),
            "qvel": (np.full(16, -self.max_qvel), np.full(16, self.max_qvel)),
            "cube_pose": (
                np.concatenate([self.ws_low, -np.ones(4)]),
                np.concatenate([self.ws_high, np.ones(4)]),
            ),
            "cube_vel": (np.full(6, -self.max_obj_vel), np.full(6, self.max_obj_vel)),
        }

    def get_reward(self) -> float:
        """Sparse 0-4 (see ``TransferCubeReward``)."""
        return float(self.reward_fn(self.data))

    def judge_success(self) -> bool:
        return self.reward_fn(self.data) == MAX_REWARD

    def get_task_description(self) -> str:
        return "pick up the red cube with the right arm and hand it over to the left arm"


class TransferCubeSampler(TaskSampler):
    """Arms at ``START_ARM_POSE``; the cube at ``sample_cube_pose(rng)``."""

    task_cls = TransferTask
    robot_name: ClassVar[str] = "stationary_ai"
    arms: ClassVar[tuple[tuple[str, str], ...]] = (
        ("left_arm", "left_gripper"),
        ("right_arm", "right_gripper"),
    )
    cameras: ClassVar[tuple[str, ...]] = tuple(STATIONARY_CAMERAS)

    def robot_config(self) -> RobotConfig:
        return stationary_ai_joint_config()

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return {"box": ("red_box_joint", "red_box")}

    def randomize_scene(self, rng: np.random.Generator) -> dict[str, Any]:
        self.env.objects["box"].set_pose(self.env.data, sample_cube_pose(rng))
        return {}
