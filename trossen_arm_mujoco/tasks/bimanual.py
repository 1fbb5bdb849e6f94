"""Shared parts of the Stationary AI (bimanual) tasks: the kit's robot, its two flavours,
free objects on the table, and the observations every bimanual task gives.

Flavours: ``"joint"`` (14 position actuators, as the real arms; config key ``scene``) and
``"ee"`` (each link_6 welded to a mocap body; ``ee_scene``); scripted policies act in
``ee``, recordings are replayed in ``joint``. Observations (float64, world frame): ``qpos``
and ``qvel`` (16, ``robot.layout.VENDOR16_LAYOUT``: rad / m, rad/s / m/s), ``env_state`` (7
per object: xyz m + quat wxyz) and ``env_vel`` (6 per object: m/s, rad/s);
``policy_observation`` adds the tool poses ``mocap_pose_left`` / ``mocap_pose_right``.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.arm_groups import MocapArmGroup
from trossen_arm_mujoco.robot.configs import (
    RobotConfig,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
)
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.observation import Part, indexed, joined
from trossen_arm_mujoco.tasks.sampler import TaskSampler
from trossen_arm_mujoco.tasks.task import Task

__all__ = ["LAYOUT_GROUPS", "ROBOT_NAME", "BimanualSampler", "BimanualTask", "finger_geoms"]

ROBOT_NAME = "stationary_ai"
LAYOUT_GROUPS = tuple(VENDOR16_LAYOUT.groups)


def finger_geoms(model: mujoco.MjModel, side: str) -> set[int]:
    """Ids of every collision geom of ``side``'s fingers (``<side>/gripper_follower*``)."""
    prefix = f"{side}/gripper_follower"
    found = {
        g
        for g in range(model.ngeom)
        if (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "").startswith(prefix)
    }
    lookup_id(model, "geom", f"{prefix}_left")  # fails with the valid names when absent
    return found


class BimanualTask(Task):
    """Base of the Stationary AI tasks. Subclasses set ``name``, ``objects`` (names of the
    sampler's free objects, in ``env_state`` order) and implement the scoring."""

    robot_name: ClassVar[str] = ROBOT_NAME
    objects: ClassVar[tuple[str, ...]] = ()
    #: Highest reward (success).
    max_reward: ClassVar[float] = 1.0

    def __init__(self, scene: Scene, config: Mapping[str, Any]):
        super().__init__(scene, config)
        view = self.robot.view
        self.layout = view.qpos_indices(LAYOUT_GROUPS)
        self.layout_dofs = view.dof_indices(LAYOUT_GROUPS)
        ranges = np.concatenate([view.get_move_group(g).joint_range for g in LAYOUT_GROUPS])
        self.qpos_low, self.qpos_high = ranges[:, 0].copy(), ranges[:, 1].copy()
        self.max_qvel = float(self.config["max_joint_velocity"])
        self.max_obj_vel = float(self.config["max_object_velocity"])
        self.ws_low = np.asarray(self.config["workspace_low"], dtype=float)
        self.ws_high = np.asarray(self.config["workspace_high"], dtype=float)
        self.bodies = [scene.objects[name] for name in self.objects]
        self._arms = {side: view.get_move_group(f"{side}_arm") for side in ("left", "right")}

    # -- observation ------------------------------------------------------------------------
    def observation_parts(self) -> list[Part]:
        """``qpos`` (16,) and ``qvel`` (16,) in the kit layout (rad / m, rad/s / m/s),
        ``env_state`` (7 per object: [xyz m, quat wxyz], in ``objects`` order) and
        ``env_vel`` (6 per object: linear m/s, angular rad/s); world frame. Live views of
        ``data`` where the values lie in order in ``qpos`` / ``qvel`` (they do in the kit
        scenes), computed otherwise."""
        data, n = self.data, len(self.objects)
        pose_low = np.tile(np.concatenate([self.ws_low, -np.ones(4)]), n)
        pose_high = np.tile(np.concatenate([self.ws_high, np.ones(4)]), n)
        v, w = self.max_qvel, self.max_obj_vel
        poses = joined([b.pose_view(data) for b in self.bodies])
        velocities = joined([b.velocity_view(data) for b in self.bodies])
        return [
            Part("qpos", indexed(data.qpos, self.layout), self.qpos_low, self.qpos_high),
            Part("qvel", indexed(data.qvel, self.layout_dofs), -v, v),
            Part("env_state", poses, pose_low, pose_high),
            Part("env_vel", velocities, -w, w),
        ]

    def env_state(self) -> np.ndarray:
        """Poses of the objects, (7 * n_objects,): [xyz m, quat wxyz] each (a copy of the
        ``env_state`` part)."""
        return np.array(self.observed.read("env_state"), dtype=float)

    def object_poses(self) -> dict[str, np.ndarray]:
        """Object name -> pose (7,), e.g. to start a replay from the same scene."""
        return {name: b.get_pose(self.data) for name, b in zip(self.objects, self.bodies)}

    def tool_pose(self, side: str) -> np.ndarray:
        """Tool-frame target of one arm, [xyz m, quat wxyz] (7,): the commanded mocap pose
        for mocap arms, the current ``ee_site`` pose for joint arms."""
        arm = self._arms[side]
        if isinstance(arm, MocapArmGroup):
            return arm.get_ctrl(self.data)
        return arm.get_frame_pose(self.data)

    def policy_observation(self) -> dict[str, np.ndarray]:
        """``get_observation`` plus ``mocap_pose_left`` / ``mocap_pose_right`` (tool poses)."""
        obs = self.get_observation()
        obs["mocap_pose_left"] = self.tool_pose("left")
        obs["mocap_pose_right"] = self.tool_pose("right")
        return obs

    def left_touches_object(self) -> bool:
        """Whether the left fingers touch the task's object now (eval's rollout analysis
        reads it at a hand-over's release); False for a task that does not say."""
        return False

    def judge_success(self) -> bool:
        """The reward is ``max_reward`` (one reward evaluation per ``score``)."""
        return self.current_reward() >= self.max_reward


class BimanualSampler(TaskSampler):
    """Base of the Stationary AI samplers: the kit robot in either flavour, arms starting at
    ``START_ARM_POSE`` (the scene keyframe) and cameras of the kit."""

    robot_name: ClassVar[str] = ROBOT_NAME
    arms: ClassVar[tuple[tuple[str, str], ...]] = (
        ("left_arm", "left_gripper"),
        ("right_arm", "right_gripper"),
    )
    cameras: ClassVar[tuple[str, ...]] = tuple(STATIONARY_CAMERAS)

    def robot_config(self) -> RobotConfig:
        return stationary_ai_joint_config()

    def ee_robot_config(self) -> RobotConfig:
        return stationary_ai_mocap_config()
