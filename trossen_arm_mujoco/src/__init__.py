"""The vendor's current Python API (Trossen's ``trossen_arm_mujoco.src``): the differential-IK
``Controller`` and ``RobotType``, over this project's robot layer.

Docs: docs/vendor-api.md.
"""

from trossen_arm_mujoco.src.controller import Controller
from trossen_arm_mujoco.src.robot_types import RobotType

__all__ = ["Controller", "RobotType"]
