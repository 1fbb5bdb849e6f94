"""Robot configs: which move groups a robot has, its initial joints, command modes and
joint speed limits.

Configs are plain data; ``RobotConfig.build_view(model)`` looks every name up once.

Docs: docs/concepts/models.md, docs/concepts/architecture.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.arm_groups import ArmMoveGroup, MocapArmGroup
from trossen_arm_mujoco.robot.base_group import (
    CarriedRobotBaseGroup,
    FreeJointRobotBaseGroup,
    ImmobileRobotBaseGroup,
    MocapRobotBaseGroup,
    RobotBaseGroup,
)
from trossen_arm_mujoco.robot.checks import check_velocity_limits, model_and_data
from trossen_arm_mujoco.robot.diff_drive import BaseVelocityLimits, DiffDriveBaseGroup
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.layout import (
    ARM_JOINTS,
    FINGER_JOINTS,
    GRIPPER_OPEN,
    START_ARM_POSE,
    VENDOR16_LAYOUT,
)
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.robot_view import RobotView

__all__ = [
    "ACTUATED_FINGER",
    "BASE_KINDS",
    "GROUP_KINDS",
    "JOINT_VELOCITY_LIMITS",
    "MOBILE_AI_BASE_HOME",
    "MOBILE_AI_BASE_LIMITS",
    "MOBILE_AI_WHEEL_RADIUS",
    "START_ARM",
    "START_FINGERS",
    "MoveGroupSpec",
    "RobotConfig",
    "mobile_ai_config",
    "qpos16_to_dict",
    "stationary_ai_joint_config",
    "stationary_ai_mocap_config",
    "wxai_config",
]

#: MoveGroupSpec kinds of base groups (the robot frame): fixed to the world, on a mocap
#: body (teleportable), on a free joint, carried by a moving body (an arm's mount on a mobile
#: base), a wheeled differential-drive base.
BASE_KINDS: tuple[str, ...] = (
    "base",
    "mocap_base",
    "free_joint_base",
    "carried_base",
    "diff_drive_base",
)
GROUP_KINDS: tuple[str, ...] = ("arm", "mocap_arm", "gripper", *BASE_KINDS)

START_ARM = list(START_ARM_POSE[:6])
START_FINGERS = [GRIPPER_OPEN, GRIPPER_OPEN]
ACTUATED_FINGER = "left_carriage_joint"  # the joint the "gripper" actuator drives

JOINT_VELOCITY_LIMITS: dict[str, float] = {
    "joint_0": 3.375,
    "joint_1": 3.375,
    "joint_2": 3.375,
    "joint_3": 7.0,
    "joint_4": 7.0,
    "joint_5": 7.0,
    "right_carriage_joint": 0.0875,
    "left_carriage_joint": 0.0875,
}
"""Velocity limits of the real WidowX AI arm (its URDF), by unprefixed joint name:
rad/s for the revolute joints, m/s for the gripper carriages."""


@dataclass(frozen=True)
class MoveGroupSpec:
    """How to build one move group.

    kind: "arm" (joint actuators + tool frame), "mocap_arm", "gripper", or a base: "base"
        (immobile, ``base_body``), "mocap_base" (``base_body`` is a mocap body) or
        "free_joint_base" (``joints`` is the one free joint).
    base: id of the base group whose pose is this group's robot frame ("" for none).
    velocity_limits: max speed per control value, rad/s (hinge) or m/s (slide): one per
        actuator for an arm, one for a gripper (its actuated finger); None for no limit
        (mocap arms and bases take none). Joint-position controllers, and the IK modes of
        joint-actuated arms, move the control by at most ``velocity_limits * ctrl_dt`` a tick.
    rate_limit: False turns the rate limiting off while keeping ``velocity_limits`` on record.
    wheel_radius, base_limits: of a "diff_drive_base" (``joints``: its free joint then the
        left and right wheel hinges; ``actuators``: the two wheels' velocity actuators):
        rolling radius (m) and ``BaseVelocityLimits`` (x.vel m/s, theta.vel rad/s).
    """

    kind: str
    joints: tuple[str, ...] = ()
    actuators: tuple[str, ...] = ()
    frame_site: str = ""
    mocap_body: str = ""
    base_body: str = ""
    base: str = ""
    velocity_limits: tuple[float, ...] | None = None
    rate_limit: bool = True
    wheel_radius: float = 0.0
    base_limits: BaseVelocityLimits | None = None

    def __post_init__(self) -> None:
        if self.velocity_limits is not None:
            limits = self.checked_velocity_limits(f"'{self.kind}' group", self.velocity_limits)
            object.__setattr__(self, "velocity_limits", limits)

    def checked_velocity_limits(self, name: str, limits: Sequence[float]) -> tuple[float, ...]:
        """``limits`` validated for this kind of group (one-line UserError naming ``name``)."""
        size = {"arm": len(self.actuators), "gripper": 1}.get(self.kind)
        if size is None:
            raise UserError(f"{name}: a '{self.kind}' move group takes no velocity limits")
        return tuple(float(v) for v in check_velocity_limits(name, limits, size))

    @property
    def enforced_velocity_limits(self) -> tuple[float, ...] | None:
        """The limits controllers enforce: ``velocity_limits`` unless ``rate_limit`` is off."""
        return self.velocity_limits if self.rate_limit else None

    def build(self, model: mujoco.MjModel | mujoco.MjData, name: str) -> MoveGroup:
        """The move group on ``model`` (or bound to an ``MjData``); its ``robot_base_group``
        is linked by ``RobotConfig.build_view``."""
        group: MoveGroup
        if self.kind == "arm":
            group = ArmMoveGroup(model, name, self.joints, self.actuators, self.frame_site)
        elif self.kind == "mocap_arm":
            group = MocapArmGroup(model, name, self.joints, self.mocap_body, self.frame_site)
        elif self.kind == "gripper":
            group = GripperGroup(model, name, self.joints, self.actuators[0])
        elif self.kind == "base":
            group = ImmobileRobotBaseGroup(model, name, self.base_body)
        elif self.kind == "mocap_base":
            group = MocapRobotBaseGroup(model, name, self.base_body)
        elif self.kind == "free_joint_base":
            if len(self.joints) != 1:
                raise UserError(f"{name}: a free_joint_base takes its one free joint in joints")
            group = FreeJointRobotBaseGroup(model, name, self.joints[0])
        elif self.kind == "carried_base":
            group = CarriedRobotBaseGroup(model, name, self.base_body)
        elif self.kind == "diff_drive_base":
            if len(self.joints) != 3 or len(self.actuators) != 2:
                raise UserError(
                    f"{name}: a diff_drive_base takes its free joint and two wheel joints in "
                    "joints, the two wheel actuators in actuators"
                )
            group = DiffDriveBaseGroup(
                model, name, self.joints[0], self.joints[1:], self.actuators, self.wheel_radius
            )
            group.base_limits = self.base_limits
        else:
            raise unknown_name_error("move group kind", self.kind, GROUP_KINDS)
        group.set_velocity_limits(self.enforced_velocity_limits)
        return group


@dataclass(frozen=True)
class RobotConfig:
    """A robot: its move groups, initial joint positions and command mode per group.

    Joint speed limits live in the group specs (``MoveGroupSpec.velocity_limits``); change
    them with ``with_velocity_limits``, switch them off with ``with_rate_limit(False)``.
    """

    name: str
    groups: dict[str, MoveGroupSpec]
    init_qpos: dict[str, list[float]] = field(default_factory=dict)
    command_mode: dict[str, str] = field(default_factory=dict)

    def build_view(self, model: mujoco.MjModel | mujoco.MjData) -> RobotView:
        """The robot view on ``model``, or bound to an ``MjData`` (then every group reads and
        writes it). Each group's ``robot_base_group`` is the group its spec's ``base`` names."""
        m, data = model_and_data(model)
        groups = {n: s.build(m, n) for n, s in self.groups.items()}
        for name, spec in self.groups.items():
            if not spec.base:
                continue
            base = groups.get(spec.base)
            if base is None:
                raise unknown_name_error(
                    "move group", spec.base, groups, hint=f"the base of move group '{name}'"
                )
            if not isinstance(base, RobotBaseGroup):
                raise UserError(f"move group '{name}': its base '{spec.base}' is not a base group")
            groups[name].robot_base_group = base
        return RobotView(model if data is None else data, groups)

    def with_base_kind(self, kind: str) -> RobotConfig:
        """A copy whose base groups are of another kind: "base" (immobile) or "mocap_base"
        (the base body must be a mocap body of the model, e.g. made so with ``MjSpec``)."""
        if kind not in ("base", "mocap_base"):
            raise unknown_name_error("base kind", kind, ["base", "mocap_base"])
        groups = {
            n: replace(s, kind=kind) if s.kind in BASE_KINDS else s for n, s in self.groups.items()
        }
        return replace(self, groups=groups)

    def with_command_modes(self, **modes: str) -> RobotConfig:
        """A copy with some groups' command modes replaced."""
        self._check_groups(modes)
        return replace(self, command_mode={**self.command_mode, **modes})

    def with_velocity_limits(self, **limits: Sequence[float] | None) -> RobotConfig:
        """A copy with some groups' velocity limits replaced (rad/s or m/s, one per control
        value; None removes them), rate limiting on for those groups.

        Example: ``config.with_velocity_limits(gripper=[0.05])``.
        """
        self._check_groups(limits)
        groups = dict(self.groups)
        for name, lim in limits.items():
            vel = None if lim is None else groups[name].checked_velocity_limits(name, lim)
            groups[name] = replace(groups[name], velocity_limits=vel, rate_limit=True)
        return replace(self, groups=groups)

    def with_rate_limit(self, enabled: bool, *groups: str) -> RobotConfig:
        """A copy with rate limiting switched on or off for ``groups`` (default: all).

        Example: ``wxai_config().with_rate_limit(False)`` lets targets jump instantly.
        """
        self._check_groups(groups)
        names = groups or tuple(self.groups)
        if enabled:
            for name in groups:
                if self.groups[name].velocity_limits is None:
                    raise UserError(
                        f"move group '{name}' has no velocity limits to enforce; "
                        "set them with with_velocity_limits"
                    )
        new = dict(self.groups)
        for name in names:
            new[name] = replace(new[name], rate_limit=enabled)
        return replace(self, groups=new)

    def _check_groups(self, names) -> None:
        for group in names:
            if group not in self.groups:
                raise unknown_name_error("move group", group, self.groups)


def _arm_groups(prefix: str, mocap: bool, side: str = "") -> dict[str, MoveGroupSpec]:
    """base, arm and gripper specs of one arm; joint-actuated groups carry the URDF limits
    (``JOINT_VELOCITY_LIMITS``), mocap arms none (the weld drives them)."""
    g = f"{side}_" if side else ""
    joints = tuple(prefix + j for j in ARM_JOINTS)
    if mocap:
        arm = MoveGroupSpec(
            "mocap_arm", joints, mocap_body=f"mocap_{side}", frame_site=f"{prefix}ee_site"
        )
    else:
        arm = MoveGroupSpec(
            "arm",
            joints,
            tuple(prefix + j for j in ARM_JOINTS),
            frame_site=f"{prefix}ee_site",
            velocity_limits=tuple(JOINT_VELOCITY_LIMITS[j] for j in ARM_JOINTS),
        )
    return {
        f"{g}base": MoveGroupSpec("base", base_body=f"{prefix}base_link"),
        f"{g}arm": replace(arm, base=f"{g}base"),
        f"{g}gripper": MoveGroupSpec(
            "gripper",
            tuple(prefix + j for j in FINGER_JOINTS),
            (f"{prefix}gripper",),
            base=f"{g}base",
            velocity_limits=(JOINT_VELOCITY_LIMITS[ACTUATED_FINGER],),
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


#: Rolling radius of the Mobile AI's driven wheels (m): the axle height of the Mobile AI URDF
#: (base_link 0.211 m above the floor, wheel joints 0.1259 m below it).
MOBILE_AI_WHEEL_RADIUS = 0.0851
#: The Mobile AI base at rest at the origin: base_joint [x, y, z, qw, qx, qy, qz] (base_link
#: 0.211 m above the floor), then the two wheel angles (rad).
MOBILE_AI_BASE_HOME = [0.0, 0.0, 0.211, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
#: The real base's command limits: trossen_slate's ``set_cmd_vel`` clips x.vel to +-1.0 m/s
#: and theta.vel to +-1.0 rad/s (the SLATE's published top speed, 3.6 km/h, is 1.0 m/s).
#: The wheel speeds ramp at 0.8 m/s^2 (own choice, no published figure): under the 0.97
#: m/s^2 that the wheels' 4 N m (URDF) give the 96.8 kg robot (2 * 4 / 0.0851 / 96.8), so
#: that the wheel servos never saturate and the base keeps the commanded curvature while it
#: speeds up (with both wheels at their torque limit it drove straight ahead instead).
MOBILE_AI_BASE_LIMITS = BaseVelocityLimits(x_vel=1.0, theta_vel=1.0, acceleration=0.8)


def mobile_ai_config() -> RobotConfig:
    """Mobile AI (``assets/mobile_ai/mobile_ai.xml`` and ``mobile_ai_scene.xml``).

    Groups: ``base`` (the differential-drive base, command mode ``base_velocity``:
    [x.vel m/s, theta.vel rad/s], within ``MOBILE_AI_BASE_LIMITS``), then as on the
    Stationary AI ``left_base``/``left_arm``/``left_gripper`` and the right ones (joint
    actuators, the arms' URDF speed limits); the arms' bases ride on the mobile base.
    """
    groups: dict[str, MoveGroupSpec] = {
        "base": MoveGroupSpec(
            "diff_drive_base",
            ("base_joint", "left_wheel", "right_wheel"),
            ("left_wheel", "right_wheel"),
            wheel_radius=MOBILE_AI_WHEEL_RADIUS,
            base_limits=MOBILE_AI_BASE_LIMITS,
        )
    }
    init: dict[str, list[float]] = {"base": list(MOBILE_AI_BASE_HOME)}
    modes: dict[str, str] = {"base": "base_velocity"}
    for side in ("left", "right"):
        arm = _arm_groups(f"{side}/", mocap=False, side=side)
        arm[f"{side}_base"] = replace(arm[f"{side}_base"], kind="carried_base")
        groups.update(arm)
        init[f"{side}_arm"] = START_ARM
        init[f"{side}_gripper"] = START_FINGERS
        modes[f"{side}_arm"] = "joint_position"
        modes[f"{side}_gripper"] = "joint_position"
    return RobotConfig("mobile_ai", groups, init, modes)


def qpos16_to_dict(qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Split the 16-value kit layout into per-group joint vectors (``VENDOR16_LAYOUT.split``)."""
    return {g: v.copy() for g, v in VENDOR16_LAYOUT.split(np.asarray(qpos, dtype=float)).items()}
