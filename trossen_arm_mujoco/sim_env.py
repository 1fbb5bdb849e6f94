"""Joint-position simulation of the Stationary AI kit, behaving like the real arms.

Action, 16 values in the qpos layout: ``[left joint_0..5 (rad), left fingers x2 (m), right
joint_0..5, right fingers x2]``. Each arm's 6 joints and its gripper (finger travel, the
second finger value, index 7 / 15) go to position actuators; the coupled finger values at
index 6 / 14 are not commanded separately.

Run ``python trossen_arm_mujoco/sim_env.py`` for a short demo (live viewer with a display,
camera PNGs without one).
"""

from __future__ import annotations

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import os
    import sys

    sys.path[0] = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    os.environ.setdefault("MUJOCO_GL", "egl")  # as the package does, before mujoco loads

import numpy as np
from dm_control.mujoco.engine import Physics

from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.robot.configs import RobotConfig, stationary_ai_joint_config
from trossen_arm_mujoco.tasks.stationary import LAYOUT_GROUPS, StationaryTaskBase
from trossen_arm_mujoco.tasks.transfer_cube import MAX_REWARD
from trossen_arm_mujoco.utils import sample_box_pose

__all__ = ["BOX_POSE", "TransferCubeTask", "TrossenAIStationaryTask"]

#: Cube pose used by ``TransferCubeTask`` at the next reset when no ``box_pose`` is given
#: (vendor-compatible hand-over: set ``BOX_POSE[0] = pose`` before ``env.reset()``).
BOX_POSE: list[np.ndarray | None] = [None]


class TrossenAIStationaryTask(StationaryTaskBase):
    """Bimanual task with joint position actuators (scene ``trossen_ai_scene_joint.xml``).

    Subclass it and override ``initialize_episode(physics)`` (e.g. inside
    ``physics.reset_context()`` set ``physics.named.data.qpos[:16] = START_ARM_POSE``, then
    call ``super().initialize_episode(physics)``), ``get_env_state`` and ``get_reward``.
    """

    DEFAULT_XML = "stationary_ai/trossen_ai_scene_joint.xml"

    def robot_config(self) -> RobotConfig:
        return stationary_ai_joint_config()

    def action_bounds(self, physics: Physics):
        """Joint limits in the qpos layout (rad / m)."""
        view = self.robot(physics).view
        ranges = np.concatenate([view.group(g).joint_range for g in LAYOUT_GROUPS])
        return ranges[:, 0].copy(), ranges[:, 1].copy()

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        return {
            "left_arm": action[0:6],
            "left_gripper": action[7:8],
            "right_arm": action[8:14],
            "right_gripper": action[15:16],
        }

    def tool_target(self, physics: Physics, arm: str) -> np.ndarray:
        """The arm's current tool-frame (ee_site) pose [xyz, quat wxyz], world frame."""
        return self.robot(physics).view.group(arm).get_frame_pose(physics.data.ptr)


class TransferCubeTask(TrossenAIStationaryTask):
    """Cube transfer in the joint env; the cube starts at ``box_pose`` (or ``BOX_POSE[0]``,
    or a pose sampled from this task's generator)."""

    def __init__(self, *args, box_pose: np.ndarray | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.box_pose = None if box_pose is None else np.asarray(box_pose, dtype=float)
        self.max_reward = MAX_REWARD

    def initialize_episode(self, physics: Physics) -> None:
        pose = self.box_pose if self.box_pose is not None else BOX_POSE[0]
        if pose is None:
            pose = sample_box_pose(self.rng)
        with physics.reset_context():
            physics.named.data.qpos[:16] = START_ARM_POSE
            physics.named.data.qpos[-7:] = pose
        super().initialize_episode(physics)

    def get_env_state(self, physics: Physics) -> np.ndarray:
        """Cube pose [xyz, quat wxyz], shape (7,)."""
        return physics.data.qpos.copy()[16:]

    def get_reward(self, physics: Physics) -> int:
        return self.transfer_reward(physics)


if __name__ == "__main__":
    from trossen_arm_mujoco.demo import demo_main

    raise SystemExit(demo_main("joint"))
