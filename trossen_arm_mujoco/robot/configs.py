"""Robot configs: which move groups a robot has, its initial joints and command modes.

Configs are plain data; ``RobotConfig.build_view(model)`` looks every name up once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from trossen_arm_mujoco.constants import GRIPPER_OPEN, START_ARM_POSE
from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.robot.move_group import (
    ArmMoveGroup,
    GripperGroup,
    ImmobileBaseGroup,
    MocapArmGroup,
    MoveGroup,
)
from trossen_arm_mujoco.robot.robot_view import RobotView

ARM_JOINTS = [f"joint_{i}" for i in range(6)]
FINGER_JOINTS = ["right_carriage_joint", "left_carriage_joint"]
START_ARM = list(START_ARM_POSE[:6])
START_FINGERS = [GRIPPER_OPEN, GRIPPER_OPEN]


@dataclass(frozen=True)
class MoveGroupSpec:
    """How to build one move group.

    kind: "arm" (joint actuators + tool frame), "mocap_arm", "gripper" or "base".
    """

    kind: str
    joints: tuple[str, ...] = ()
    actuators: tuple[str, ...] = ()
    frame_site: str = ""
    mocap_body: str = ""
    base_body: str = ""

    def build(self, model: mujoco.MjModel, name: str) -> MoveGroup:
        if self.kind == "arm":
            return ArmMoveGroup(model, name, self.joints, self.actuators, self.frame_site)
        if self.kind == "mocap_arm":
            return MocapArmGroup(model, name, self.joints, self.mocap_body, self.frame_site)
        if self.kind == "gripper":
            return GripperGroup(model, name, self.joints, self.actuators[0])
        if self.kind == "base":
            return ImmobileBaseGroup(model, name, self.base_body)
        raise unknown_name_error(
            "move group kind", self.kind, ["arm", "mocap_arm", "gripper", "base"]
        )


@dataclass(frozen=True)
class RobotConfig:
    """A robot: its move groups, initial joint positions and command mode per group."""

    name: str
    groups: dict[str, MoveGroupSpec]
    init_qpos: dict[str, list[float]] = field(default_factory=dict)
    command_mode: dict[str, str] = field(default_factory=dict)

    def build_view(self, model: mujoco.MjModel) -> RobotView:
        return RobotView(model, {n: s.build(model, n) for n, s in self.groups.items()})

    def with_command_modes(self, **modes: str) -> RobotConfig:
        """A copy with some groups' command modes replaced."""
        for group in modes:
            if group not in self.groups:
                raise unknown_name_error("move group", group, self.groups)
        return RobotConfig(self.name, self.groups, self.init_qpos, {**self.command_mode, **modes})


def _arm_groups(prefix: str, mocap: bool, side: str = "") -> dict[str, MoveGroupSpec]:
    g = f"{side}_" if side else ""
    joints = tuple(prefix + j for j in ARM_JOINTS)
    if mocap:
        arm = MoveGroupSpec(
            "mocap_arm", joints, mocap_body=f"mocap_{side}", frame_site=f"{prefix}ee_site"
        )
    else:
        arm = MoveGroupSpec(
            "arm", joints, tuple(prefix + j for j in ARM_JOINTS), frame_site=f"{prefix}ee_site"
        )
    return {
        f"{g}base": MoveGroupSpec("base", base_body=f"{prefix}base_link"),
        f"{g}arm": arm,
        f"{g}gripper": MoveGroupSpec(
            "gripper", tuple(prefix + j for j in FINGER_JOINTS), (f"{prefix}gripper",)
        ),
    }


def wxai_config(command_mode: str = "joint_position") -> RobotConfig:
    """Single wxai arm (``assets/wxai/wxai_follower.xml`` and scenes that include it).

    Groups: base, arm (6 joints, tool frame ``ee_site``), gripper (2 coupled fingers).
    """
    return RobotConfig(
        name="wxai",
        groups=_arm_groups("", mocap=False),
        init_qpos={"arm": START_ARM, "gripper": START_FINGERS},
        command_mode={"arm": command_mode, "gripper": "joint_position"},
    )


def _stationary(mocap: bool) -> RobotConfig:
    groups: dict[str, MoveGroupSpec] = {}
    init: dict[str, list[float]] = {}
    modes: dict[str, str] = {}
    for side in ("left", "right"):
        groups.update(_arm_groups(f"{side}/", mocap, side))
        init[f"{side}_arm"] = START_ARM
        init[f"{side}_gripper"] = START_FINGERS
        modes[f"{side}_arm"] = "ee_pose" if mocap else "joint_position"
        modes[f"{side}_gripper"] = "joint_position"
    return RobotConfig("stationary_ai", groups, init, modes)


def stationary_ai_joint_config() -> RobotConfig:
    """Stationary AI kit with joint actuators (``trossen_ai_scene_joint.xml``)."""
    return _stationary(mocap=False)


def stationary_ai_mocap_config() -> RobotConfig:
    """Stationary AI kit with mocap-driven arms (``trossen_ai_scene.xml``)."""
    return _stationary(mocap=True)


def qpos16_to_dict(qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Split the 16-value kit layout into per-group joint vectors."""
    q = np.asarray(qpos, dtype=float)
    return {
        "left_arm": q[0:6],
        "left_gripper": q[6:8],
        "right_arm": q[8:14],
        "right_gripper": q[14:16],
    }
