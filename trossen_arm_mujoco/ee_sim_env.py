"""End-effector (mocap) simulation of the Stationary AI kit.

Each arm's link_6 is welded to a mocap body; the action moves the mocap bodies (tool-frame
poses) and the gripper actuators. Action, 16 values:
``[left xyz (m), left quat wxyz, left gripper (m), right xyz, right quat wxyz, right gripper]``
(world frame; gripper = finger travel, 0 closed .. 0.044 open).

Run ``python trossen_arm_mujoco/ee_sim_env.py`` for a short demo (live viewer with a display,
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

from trossen_arm_mujoco.constants import GRIPPER_OPEN
from trossen_arm_mujoco.robot.configs import RobotConfig, stationary_ai_mocap_config
from trossen_arm_mujoco.tasks.stationary import StationaryTaskBase
from trossen_arm_mujoco.tasks.transfer_cube import MAX_REWARD
from trossen_arm_mujoco.utils import sample_box_pose

__all__ = ["TransferCubeEETask", "TrossenAIStationaryEETask"]


class TrossenAIStationaryEETask(StationaryTaskBase):
    """Bimanual task with mocap-driven arms (scene ``stationary_ai/trossen_ai_scene.xml``).

    Subclass it and override ``initialize_episode(physics)`` (call
    ``self.initialize_robots(physics)`` first and ``super().initialize_episode(physics)``
    last), ``get_env_state(physics)`` and ``get_reward(physics)``.
    """

    DEFAULT_XML = "stationary_ai/trossen_ai_scene.xml"

    def robot_config(self) -> RobotConfig:
        return stationary_ai_mocap_config()

    def action_bounds(self, physics: Physics):
        pose_low = [-1.0, -1.0, 0.0, -1, -1, -1, -1]
        pose_high = [1.0, 1.0, 1.5, 1, 1, 1, 1]
        low = np.array(pose_low + [0.0] + pose_low + [0.0])
        high = np.array(pose_high + [GRIPPER_OPEN] + pose_high + [GRIPPER_OPEN])
        return low, high

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        return {
            "left_arm": action[0:7],
            "left_gripper": action[7:8],
            "right_arm": action[8:15],
            "right_gripper": action[15:16],
        }

    def tool_target(self, physics: Physics, arm: str) -> np.ndarray:
        """The mocap pose commanded to ``arm`` ([xyz, quat wxyz], world)."""
        return self.robot(physics).view.group(arm).get_ctrl(physics.data.ptr)


class TransferCubeEETask(TrossenAIStationaryEETask):
    """Pick the cube with the right arm and hand it to the left arm; reward 0-4."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.max_reward = MAX_REWARD

    def initialize_episode(self, physics: Physics) -> None:
        self.initialize_robots(physics)
        cube_pose = sample_box_pose(self.rng)
        box_start_idx = physics.model.name2id("red_box_joint", "joint")
        np.copyto(physics.data.qpos[box_start_idx : box_start_idx + 7], cube_pose)
        super().initialize_episode(physics)

    def get_env_state(self, physics: Physics) -> np.ndarray:
        """Cube pose [xyz, quat wxyz], shape (7,)."""
        return physics.data.qpos.copy()[16:]

    def get_reward(self, physics: Physics) -> int:
        return self.transfer_reward(physics)


if __name__ == "__main__":
    from trossen_arm_mujoco.demo import demo_main

    raise SystemExit(demo_main("ee"))
