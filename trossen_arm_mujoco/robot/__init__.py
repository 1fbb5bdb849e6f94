"""What a robot is: move groups, the robot view, controllers, kinematics and the robot."""

from trossen_arm_mujoco.robot.configs import (
    JOINT_VELOCITY_LIMITS,
    RobotConfig,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.robot.robot_view import RobotView

__all__ = [
    "JOINT_VELOCITY_LIMITS",
    "Robot",
    "RobotConfig",
    "RobotView",
    "stationary_ai_joint_config",
    "stationary_ai_mocap_config",
    "wxai_config",
]
