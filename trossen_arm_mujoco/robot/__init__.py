"""What a robot is: move groups, the robot view, controllers, kinematics and the robot.

Docs: docs/concepts/architecture.md (the robot layer), docs/reference/robot-sim.md.
"""

from trossen_arm_mujoco.robot.arm_groups import (
    ArmMoveGroup,
    MocapArmGroup,
    SimplyActuatedMoveGroup,
)
from trossen_arm_mujoco.robot.base_group import (
    CarriedRobotBaseGroup,
    FreeJointRobotBaseGroup,
    ImmobileRobotBaseGroup,
    MocapRobotBaseGroup,
    RobotBaseGroup,
)
from trossen_arm_mujoco.robot.configs import (
    JOINT_VELOCITY_LIMITS,
    RobotConfig,
    mobile_ai_config,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.diff_drive import BaseVelocityLimits, DiffDriveBaseGroup
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.parallel_kinematics import BatchIKResult, ParallelKinematics
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.robot.robot_kinematics import IKResult, RobotKinematics
from trossen_arm_mujoco.robot.robot_view import RobotView

__all__ = [
    "JOINT_VELOCITY_LIMITS",
    "ArmMoveGroup",
    "BaseVelocityLimits",
    "BatchIKResult",
    "CarriedRobotBaseGroup",
    "DiffDriveBaseGroup",
    "FreeJointRobotBaseGroup",
    "GripperGroup",
    "IKResult",
    "ImmobileRobotBaseGroup",
    "MJCFFrameMixin",
    "MocapArmGroup",
    "MocapRobotBaseGroup",
    "MoveGroup",
    "ParallelKinematics",
    "Robot",
    "RobotBaseGroup",
    "RobotConfig",
    "RobotKinematics",
    "RobotView",
    "SimplyActuatedMoveGroup",
    "mobile_ai_config",
    "stationary_ai_joint_config",
    "stationary_ai_mocap_config",
    "wxai_config",
]
