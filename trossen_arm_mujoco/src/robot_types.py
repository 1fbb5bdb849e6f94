"""The robots the vendor's ``Controller`` API knows, and which move groups of this project's
robot configs one controller drives.

``RobotType`` has the vendor's members and values (``"wxai"``, ``"stationary_ai"``,
``"mobile_ai"``). ``arm_config(robot_type, model, ee_site_name)`` picks the arm whose tool
frame is the named site: the project's ``RobotConfig`` cut down to that arm's base, arm and
gripper groups. The vendor's names of the two-arm kits' sites and joints
(``follower_left_ee_site``, ``follower_left_joint_0``) are accepted for this project's
(``left/ee_site``, ``left/joint_0``).

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from enum import Enum

import mujoco

from trossen_arm_mujoco.assets import MOBILE_AI_TABLE_TOP, STATIONARY_TABLE_TOP
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.configs import (
    RobotConfig,
    mobile_ai_config,
    stationary_ai_joint_config,
    wxai_config,
)

__all__ = ["RobotType", "RobotTypeError", "arm_config", "to_project_name"]


class RobotTypeError(UserError, ValueError):
    """An unknown robot type: a one-line ``UserError`` that is also the ``ValueError`` an
    ``Enum`` lookup raises."""


class RobotType(Enum):
    """The Trossen AI robots: a single WidowX AI arm, the Stationary AI and Mobile AI kits."""

    WXAI = "wxai"
    STATIONARY_AI = "stationary_ai"
    MOBILE_AI = "mobile_ai"

    @classmethod
    def _missing_(cls, value: object) -> RobotType:
        raise RobotTypeError(
            f"unknown robot type {value!r}; valid robot types: "
            + ", ".join(f"RobotType.{m.name} ({m.value!r})" for m in cls)
        )


#: robot type -> (its joint-actuated robot config, table-top height (m, world z) of its scenes)
_ROBOTS: dict[RobotType, tuple[Callable[[], RobotConfig], float | None]] = {
    RobotType.WXAI: (wxai_config, 0.0),
    RobotType.STATIONARY_AI: (stationary_ai_joint_config, STATIONARY_TABLE_TOP),
    RobotType.MOBILE_AI: (mobile_ai_config, MOBILE_AI_TABLE_TOP),
}


def as_robot_type(robot_type: RobotType | str) -> RobotType:
    """``robot_type`` as a ``RobotType``: a member, or its value (``"wxai"``); anything else
    is a one-line ``RobotTypeError`` listing the valid ones."""
    if isinstance(robot_type, RobotType):
        return robot_type
    return RobotType(robot_type)


def to_project_name(name: str) -> str:
    """This project's name for a vendor name of a two-arm kit: ``follower_left_X`` ->
    ``left/X`` (other names unchanged)."""
    for side in ("left", "right"):
        prefix = f"follower_{side}_"
        if name.startswith(prefix):
            return f"{side}/{name[len(prefix) :]}"
    return name


def default_table_height(robot_type: RobotType) -> float | None:
    """Table-top height (m, world z) of the robot type's shipped scenes."""
    return _ROBOTS[robot_type][1]


def arm_config(
    robot_type: RobotType, model: mujoco.MjModel, ee_site_name: str
) -> tuple[RobotConfig, str, str]:
    """(config, arm group id, gripper group id) of the arm whose tool frame is ``ee_site_name``
    (a site of ``model``, this project's or the vendor's name).

    The config keeps that arm's base, arm and gripper groups, in ``joint_position`` mode (the
    Mobile AI's wheeled base is not among them: drive it with ``robot.configs.mobile_ai_config``
    and its ``base_velocity`` controller). A site that is no arm's tool frame is a one-line
    ``UserError`` listing the tool frames.

    Args:
        robot_type: the robot (``RobotType``).
        model: its compiled model.
        ee_site_name: the arm's tool frame site.
    """
    full = _ROBOTS[robot_type][0]()
    site = to_project_name(ee_site_name)
    arms = {s.frame_site: n for n, s in full.groups.items() if s.kind == "arm"}
    if site not in arms:
        raise unknown_name_error(
            f"end-effector site of {robot_type.name}",
            ee_site_name,
            arms,
            hint="pass ee_site_name=",
        )
    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site) < 0:
        raise UserError(
            f"the model has no site '{site}': load a {robot_type.name} scene of this project "
            "(trossen_arm_mujoco/assets)"
        )
    arm = arms[site]
    side = arm[: -len("arm")]  # "" or "left_"
    keep = {f"{side}base", f"{side}arm", f"{side}gripper"}
    config = replace(
        full,
        groups={n: s for n, s in full.groups.items() if n in keep},
        init_qpos={n: v for n, v in full.init_qpos.items() if n in keep},
        command_mode={n: "joint_position" for n in full.command_mode if n in keep},
    )
    return config, arm, f"{side}gripper"
