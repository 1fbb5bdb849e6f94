"""The vendor's differential-IK controller API, as a thin layer over this project's robot layer.

``Controller(model, data, robot_type, ee_site_name, arm_joint_names, gripper_joint_names,
ik_scale, ik_damping)`` drives one arm by its end-effector pose, like Trossen's
``trossen_arm_mujoco.src.controller.Controller``: call ``set_ee_pose`` once per physics step
(the caller steps physics; the controller only writes ``data.ctrl``). One step: the pose
error e (m, and a rotation vector in rad, world frame) -> dq = ``ik_scale`` J^T (J J^T +
``ik_damping``^2 I)^-1 e -> joint targets within the joint limits -> the project's ``Robot``
(rate-limited, held above the safety floor). A target beyond the arm's reach is refused (one
``note:`` line; ``out_of_reach``, ``out_of_reach_count``) and the last feasible one kept.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, note
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.kinematics import (
    Kinematics,
    damped_least_squares,
    orientation_error,
)
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.src.robot_types import (
    RobotType,
    arm_config,
    as_robot_type,
    default_table_height,
    to_project_name,
)

__all__ = [
    "DEFAULT_IK_DAMPING",
    "DEFAULT_IK_SCALE",
    "GRIPPER_CLOSED_POSITION",
    "GRIPPER_OPEN_POSITION",
    "Controller",
    "RobotType",
]

#: The vendor's defaults (its README states ik_scale 1.0; its code, which this follows, 0.5).
DEFAULT_IK_SCALE = 0.5
DEFAULT_IK_DAMPING = 0.03
#: The vendor's gripper constants (m of finger travel): fully open, and the width its demos
#: close to on their 50 mm cube (``close_gripper`` here closes fully; see docs/vendor-api.md).
GRIPPER_OPEN_POSITION = 0.044
GRIPPER_CLOSED_POSITION = 0.022

_TABLE = object()  # table_height default: the robot type's scenes' table top


class Controller:
    """End-effector control of one arm through damped-least-squares differential IK.

    Args:
        model, data: the compiled scene and its state (a joint-actuated scene of this
            project: ``assets/wxai/scene_*.xml``, ``assets/stationary_ai/*_scene_joint.xml``,
            ``assets/mobile_ai/mobile_ai_scene.xml``), or the vendor's name of one
            (``assets/wxai/scene_wxai_pick_place.xml``; docs/vendor-api.md).
        robot_type: ``RobotType`` member or its value (``"wxai"``).
        ee_site_name: the arm's tool-frame site: ``"ee_site"`` on the WidowX AI; on the
            kits ``"left/ee_site"`` / ``"right/ee_site"`` (or the vendor's
            ``"follower_left_ee_site"``), which chooses the arm. The Mobile AI's base is not
            driven here (``robot.configs.mobile_ai_config``: ``base_velocity``).
        arm_joint_names, gripper_joint_names: None for the arm's own; given, they must name
            that arm's six joints in order and its gripper's finger joint(s) (project or
            vendor names); this layer always drives the whole arm.
        ik_scale: fraction of the pose error corrected per call (0-1).
        ik_damping: damping of the least squares (m; 0-0.1), against singularities.
        table_height: the safety floor (m, world z) the arm is held above; default the
            robot type's table top (WXAI 0.0, STATIONARY_AI 0.02, MOBILE_AI 0.75); None: no
            floor.

    The vendor's public attributes: ``arm_joint_ids``, ``arm_qpos_indices``,
    ``arm_dof_indices``, ``arm_actuator_ids``, ``gripper_joint_ids``,
    ``gripper_qpos_indices``, ``gripper_actuator_ids`` (lists of int indices into the model
    and data; the gripper lists have one entry per ``gripper_joint_names`` name, by default
    the actuated finger's),
    ``num_arm_joints`` (6), ``jac_pos`` and ``jac_rot`` ((3, nv) arrays: the tool frame's
    Jacobian, filled by :meth:`compute_ik_step` and :meth:`set_ee_pose`),
    ``GRIPPER_OPEN_POSITION`` and ``GRIPPER_CLOSED_POSITION``.
    """

    GRIPPER_OPEN_POSITION = GRIPPER_OPEN_POSITION
    GRIPPER_CLOSED_POSITION = GRIPPER_CLOSED_POSITION

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        robot_type: RobotType | str = RobotType.WXAI,
        ee_site_name: str = "ee_site",
        arm_joint_names: Sequence[str] | None = None,
        gripper_joint_names: Sequence[str] | None = None,
        ik_scale: float = DEFAULT_IK_SCALE,
        ik_damping: float = DEFAULT_IK_DAMPING,
        table_height: float | None = _TABLE,  # type: ignore[assignment]
    ):
        self.model = model
        self.data = data
        self.robot_type = as_robot_type(robot_type)
        self.ik_scale = float(ik_scale)
        self.ik_damping = float(ik_damping)
        config, arm_id, gripper_id = arm_config(self.robot_type, model, ee_site_name)
        self.robot = Robot(model, config, data=data)
        if table_height is _TABLE:
            table_height = default_table_height(self.robot_type)
        if table_height is not None:
            self.robot.set_safety_floor(table_height)
        self.arm_group_id, self.gripper_group_id = arm_id, gripper_id
        self.arm = self.robot.view.get_move_group(arm_id)
        self.gripper = self.robot.view.get_move_group(gripper_id)
        _check_names("arm_joint_names", arm_joint_names, self.arm.joint_names, exact=True)
        _check_names("gripper_joint_names", gripper_joint_names, self.gripper.joint_names)
        self.ee_site_id = int(self.arm.frame_site_id)
        self.kinematics = Kinematics(
            model, self.ee_site_id, self.arm.qpos_idx, self.arm.dof_idx, self.arm.joint_range
        )
        self.reach = _reach(model, self.arm.joint_ids, self.ee_site_id)
        self._first_joint = int(self.arm.joint_ids[0])
        self.out_of_reach = False
        self.out_of_reach_count = 0
        # the vendor's attributes: lists of model indices, as its controller builds them
        self.arm_joint_ids = [int(j) for j in self.arm.joint_ids]
        self.arm_qpos_indices = [int(model.jnt_qposadr[j]) for j in self.arm_joint_ids]
        self.arm_dof_indices = [int(model.jnt_dofadr[j]) for j in self.arm_joint_ids]
        self.arm_actuator_ids = [int(a) for a in self.arm.actuator_ids]
        self.gripper_joint_ids = _gripper_joints(model, self.gripper, gripper_joint_names)
        self.gripper_qpos_indices = [int(model.jnt_qposadr[j]) for j in self.gripper_joint_ids]
        self.gripper_actuator_ids = [int(self.gripper.actuator_id)] * len(self.gripper_joint_ids)
        self.num_arm_joints = len(self.arm_joint_ids)
        self.jac_pos = np.zeros((3, model.nv))
        self.jac_rot = np.zeros((3, model.nv))

    # -- state -----------------------------------------------------------------------------
    def get_ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) m, orientation quaternion (4,) [w, x, y, z]) of the tool frame,
        world frame, from the data's last kinematics."""
        position = self.data.site_xpos[self.ee_site_id].copy()
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, self.data.site_xmat[self.ee_site_id])
        return position, quat

    def get_arm_joint_positions(self) -> np.ndarray:
        """The arm's six joint positions (rad)."""
        return self.data.qpos[self.arm.qpos_idx].copy()

    def get_gripper_position(self) -> float:
        """Travel (m; 0 closed, 0.044 open) of the first gripper joint
        (``gripper_qpos_indices[0]``: by default the actuated finger), as the vendor's."""
        return float(self.data.qpos[self.gripper_qpos_indices[0]])

    # -- commands --------------------------------------------------------------------------
    def set_arm_joint_positions(self, joint_positions: np.ndarray) -> None:
        """Joint targets (6,) rad for the arm, written to its position actuators (within the
        joint ranges), as the vendor's: under plain ``mj_step`` the actuators take the arm
        there at their own pace. (``set_ee_pose`` goes through the robot layer's speed
        limits and safety floor; a later call starts from these targets.)"""
        q = _vector("joint_positions", joint_positions, self.num_arm_joints)
        low, high = self.arm.joint_range[:, 0], self.arm.joint_range[:, 1]
        self.arm.set_ctrl(self.data, np.clip(q, low, high))

    def set_gripper_position(self, position: float) -> None:
        """Gripper target (m of finger travel, within the actuator's range); the actuator
        moves the fingers there over the next physics steps."""
        cmd = np.array([float(position)])
        self.robot.update_control({self.gripper_group_id: cmd})
        self.gripper.set_ctrl(self.data, cmd)

    def open_gripper(self) -> None:
        """Open the gripper fully."""
        self.set_gripper_position(self.gripper.open_ctrl)

    def close_gripper(self) -> None:
        """Close the gripper (it stops on what it holds)."""
        self.set_gripper_position(self.gripper.closed_ctrl)

    def compute_ik_step(
        self,
        target_position: np.ndarray,
        target_orientation: np.ndarray | None = None,
        position_only: bool = False,
    ) -> np.ndarray:
        """Joint step dq (6,) rad toward the target pose (before joint limits and speed
        limits): ``ik_scale`` times the damped-least-squares solution of J dq = e.

        Args:
            target_position: (3,) the tool frame's target (m, world).
            target_orientation: (4,) target orientation, quaternion wxyz; None: position
                only.
            position_only: ignore ``target_orientation``.
        """
        return self._ik_target(target_position, target_orientation, position_only, clip=False)

    def set_ee_pose(
        self,
        target_position: np.ndarray,
        target_orientation: np.ndarray | None = None,
        position_only: bool = False,
    ) -> float:
        """One IK step toward the target pose, applied to the arm's controls.

        Args:
            target_position: (3,) m, world frame.
            target_orientation: (4,) quaternion [w, x, y, z], world frame; None (or
                ``position_only``): the orientation is left free.
        Returns:
            The position error (m) before this step; call again every physics step until
            it is small enough.
        """
        target = _vector("target_position", target_position, 3)
        position, _ = self.get_ee_pose()
        error = float(np.linalg.norm(target - position))
        base = self.data.xanchor[self._first_joint]
        if np.linalg.norm(target - base) > self.reach:
            self.out_of_reach_count += 1
            if not self.out_of_reach:
                note(
                    f"{self.arm_group_id}: target {np.round(target, 3).tolist()} m is out of "
                    f"reach ({np.linalg.norm(target - base):.3f} m from the arm's first "
                    f"joint, it reaches {self.reach:.3f} m); keeping the last feasible pose"
                )
            self.out_of_reach = True
            self.robot.compute_control(self.data)  # the last feasible targets, held
            return error
        self.out_of_reach = False
        q = self._ik_target(target, target_orientation, position_only, clip=True)
        # through the robot layer: speed limits and the safety floor
        self.robot.update_control({self.arm_group_id: q})
        self.robot.compute_control(self.data)
        return error

    def _ik_target(self, target_position, target_orientation, position_only, clip: bool):
        target = _vector("target_position", target_position, 3)
        position, quat = self.get_ee_pose()
        err = target - position
        if target_orientation is not None and not position_only:
            goal = _vector("target_orientation", target_orientation, 4)
            norm = np.linalg.norm(goal)
            if norm == 0:
                raise UserError("target_orientation must be a nonzero quaternion [w, x, y, z]")
            err = np.concatenate([err, orientation_error(goal / norm, quat)])
        twist = self.ik_scale * err
        mujoco.mj_jacSite(self.model, self.data, self.jac_pos, self.jac_rot, self.ee_site_id)
        q_next = self.kinematics.delta_step(self.data.qpos, twist, self.ik_damping)
        if clip:
            return q_next
        jac = self.kinematics.jacobian(self.data.qpos)[: len(twist)]
        return damped_least_squares(jac, twist, self.ik_damping)


def _vector(name: str, value, size: int) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (size,) or not np.isfinite(v).all():
        raise UserError(f"{name} must be {size} finite numbers, got {np.asarray(value).tolist()}")
    return v


def _check_names(what: str, given, valid: Sequence[str], exact: bool = False) -> None:
    """Names the caller passed (project or vendor names) checked against the group's."""
    if given is None:
        return
    names = [to_project_name(str(n)) for n in given]
    ok = names == list(valid) if exact else bool(names) and set(names) <= set(valid)
    if not ok:
        raise UserError(
            f"{what} {list(given)} do not match this arm's joints {list(valid)}; "
            f"pass those (or None for them)"
        )


def _gripper_joints(
    model: mujoco.MjModel, gripper: GripperGroup, names: Sequence[str] | None
) -> list[int]:
    """The vendor's ``gripper_joint_ids``: the joints of ``names`` (checked), in that order;
    None: the finger joint the gripper's actuator drives (the vendor's WidowX AI default)."""
    if names is None:
        return [int(model.actuator_trnid[gripper.actuator_id, 0])]
    return [
        int(gripper.joint_ids[gripper.joint_names.index(to_project_name(str(n)))]) for n in names
    ]


def _reach(model: mujoco.MjModel, joint_ids: Sequence[int], site_id: int) -> float:
    """Upper bound of the distance (m) from the first joint's anchor to the tool frame: the
    lengths between consecutive joint anchors and the site, which no joint angle changes."""
    scratch = mujoco.MjData(model)
    mujoco.mj_kinematics(model, scratch)
    points = [scratch.xanchor[j] for j in joint_ids] + [scratch.site_xpos[site_id]]
    return float(sum(np.linalg.norm(b - a) for a, b in zip(points, points[1:])))
