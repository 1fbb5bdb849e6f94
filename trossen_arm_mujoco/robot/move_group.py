"""Move groups: named sets of a robot's joints that are commanded together.

A move group owns the indices of its joints in ``qpos``/``qvel`` and of its actuators in
``ctrl`` (or its mocap body), looked up once at construction, and reads and writes a bound
``MjData`` through ``joint_pos``, ``joint_vel``, ``ctrl``, ``noop_ctrl`` (the data-explicit
methods, ``get_qpos(data)``, ..., work unbound). Units: hinge joints rad, slide joints m;
7-value poses [x, y, z, qw, qx, qy, qz], world frame (m); frames are 4x4 transforms. The
*root frame* is the body the chain hangs from, the *leaf frame* the last joint's body or the
named tool frame, the *robot frame* the pose of ``robot_base_group`` (else the root frame).
Frames and Jacobians are valid after ``mj_kinematics``/``mj_forward``.

Docs: docs/concepts/architecture.md (the robot layer); where each part lives:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.binding import DataBound
from trossen_arm_mujoco.robot.checks import check_velocity_limits, finite, model_and_data
from trossen_arm_mujoco.robot.frames import frame_jacobian, frame_transform, relative
from trossen_arm_mujoco.robot.joint_indices import HINGE, SLIDE, joint_indices, root_body_id
from trossen_arm_mujoco.robot.limits import frozen
from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["MoveGroup", "RobotFrame"]


class RobotFrame(Protocol):
    """What is read of a move group's robot base (a ``base_group.RobotBaseGroup``, which is
    itself a move group: named here by what it offers, so this module needs not import it)."""

    body_id: int  # the base body, whose frame is the robot frame

    @property
    def pose(self) -> np.ndarray:
        """The robot frame in the world, 4x4 (m)."""
        ...


class MoveGroup(DataBound):
    """Joints of one robot that move together.

    Args:
        model: compiled MuJoCo model, or an ``MjData`` to bind the group to at once.
        name: group name (e.g. "left_arm").
        joint_names: joints of the group, in command order (hinge or slide; base groups
            take a free joint).
        root_body: body (name or id) the group hangs from; default the parent of its first
            joint's body.

    ``velocity_limits`` (None or (ctrl_dim,), rad/s or m/s) is the speed that joint-position
    controllers hold the group's control to; see ``set_velocity_limits``.
    ``robot_base_group``: the base whose pose is this group's robot frame (set by
    ``RobotConfig.build_view``), or None.
    """

    rate_limitable = False  # whether the control is joint positions that velocity limits fit
    joint_types: tuple[int, ...] = (HINGE, SLIDE)  # the joint types a group accepts

    def __init__(
        self,
        model: mujoco.MjModel | mujoco.MjData,
        name: str,
        joint_names: Sequence[str],
        root_body: str | int | None = None,
    ):
        model, data = model_and_data(model)
        self.model = model
        self.name = name
        self.joint_names = list(joint_names)
        self.joint_ids, self.qpos_idx, self.dof_idx, self.joint_range = joint_indices(
            model, name, self.joint_names, self.joint_types
        )
        # the same as slices where consecutive (cheaper to read through, every step)
        self._qpos_sel = as_slice(self.qpos_idx)
        self._dof_sel = as_slice(self.dof_idx)
        self.actuator_ids = np.zeros(0, dtype=int)
        self.velocity_limits: np.ndarray | None = None
        self._ctrl_low = self._ctrl_high = frozen(np.zeros(0))  # ctrl_limits, shared
        self.root_body_id = root_body_id(model, root_body, self.joint_ids)
        self.leaf_frame_type = "body"
        self.leaf_frame_id = (
            int(model.jnt_bodyid[self.joint_ids[-1]]) if len(self.joint_ids) else self.root_body_id
        )
        self.robot_base_group: RobotFrame | None = None
        self._data: mujoco.MjData | None = None
        if data is not None:
            self.bind(data)

    # -- binding (DataBound) -------------------------------------------------------------
    def _binding_name(self) -> str:
        return f"move group '{self.name}'"

    def _binding_hint(self) -> str:
        return "build it from the data, bind it (group.bind(data)), or use RobotView(data, groups)"

    # -- sizes and indices ---------------------------------------------------------------
    def set_velocity_limits(self, limits: Sequence[float] | None) -> None:
        """Max speed per control value that controllers enforce, or None for no limit.

        Args:
            limits: (ctrl_dim,) speeds, rad/s for hinge joints and m/s for slide joints
                (a gripper's one value is its actuated finger's speed).
        """
        if limits is None:
            self.velocity_limits = None
            return
        if not self.rate_limitable:
            raise UserError(
                f"move group '{self.name}' ({type(self).__name__}) takes no joint-position "
                "control; velocity limits apply to joint-actuated arms and grippers"
            )
        self.velocity_limits = check_velocity_limits(self.name, limits, self.ctrl_dim)

    @property
    def n_joints(self) -> int:
        """Number of joints of the group."""
        return len(self.joint_ids)

    @property
    def pos_dim(self) -> int:
        """Length of ``joint_pos`` (7 for a free joint, else one per joint)."""
        return len(self.qpos_idx)

    @property
    def vel_dim(self) -> int:
        """Length of ``joint_vel`` (6 for a free joint, else one per joint)."""
        return len(self.dof_idx)

    @property
    def n_actuators(self) -> int:
        """Number of actuators of the group (0 for mocap and unactuated groups)."""
        return len(self.actuator_ids)

    @property
    def ctrl_dim(self) -> int:
        """Length of this group's control vector (0 for groups that cannot move)."""
        return 0

    @property
    def joint_posadr(self) -> np.ndarray:
        """Indices of the group's joints in ``qpos``, (pos_dim,)."""
        return self.qpos_idx

    @property
    def joint_veladr(self) -> np.ndarray:
        """Indices of the group's joints in ``qvel`` (dofs), (vel_dim,)."""
        return self.dof_idx

    # -- state bound to the data ---------------------------------------------------------
    @property
    def joint_pos(self) -> np.ndarray:
        """Joint positions (rad / m), (pos_dim,), a copy; set it with an array of that shape."""
        return self.get_qpos(self.data)

    @joint_pos.setter
    def joint_pos(self, value: Sequence[float]) -> None:
        self.set_qpos(self.data, value)

    @property
    def joint_vel(self) -> np.ndarray:
        """Joint velocities (rad/s / m/s), (vel_dim,), a copy; settable."""
        return self.get_qvel(self.data)

    @joint_vel.setter
    def joint_vel(self, value: Sequence[float]) -> None:
        self.set_qvel(self.data, value)

    @property
    def ctrl(self) -> np.ndarray:
        """The control applied now, (ctrl_dim,), a copy; setting it validates and clips."""
        return self.get_ctrl(self.data)

    @ctrl.setter
    def ctrl(self, value: Sequence[float]) -> None:
        self.set_ctrl(self.data, value)

    @property
    def noop_ctrl(self) -> np.ndarray:
        """A control that holds the current state, (ctrl_dim,)."""
        return self.get_noop_ctrl(self.data)

    @property
    def joint_pos_limits(self) -> np.ndarray:
        """(pos_dim, 2) [low, high] per joint position (rad / m); +-inf where unlimited."""
        return self.joint_range.copy()

    @property
    def ctrl_limits(self) -> np.ndarray:
        """(ctrl_dim, 2) [low, high] per control value (rad / m), a fresh copy;
        ``low, high = group.ctrl_limits.T`` gives the two (ctrl_dim,) bounds."""
        return np.stack([self._ctrl_low, self._ctrl_high], axis=-1).astype(float)

    # -- frames (4x4, after mj_kinematics) -----------------------------------------------
    @property
    def root_frame_to_world(self) -> np.ndarray:
        """Pose of the root frame in the world, 4x4."""
        return frame_transform(self.data, "body", self.root_body_id)

    @property
    def leaf_frame_to_world(self) -> np.ndarray:
        """Pose of the leaf frame in the world, 4x4."""
        return frame_transform(self.data, self.leaf_frame_type, self.leaf_frame_id)

    @property
    def leaf_frame_to_root(self) -> np.ndarray:
        """Pose of the leaf frame in the root frame, 4x4."""
        return relative(self.leaf_frame_to_world, self.root_frame_to_world)

    @property
    def root_frame_to_robot(self) -> np.ndarray:
        """Pose of the root frame in the robot frame, 4x4 (identity without a base)."""
        if self.robot_base_group is None:
            return np.eye(4)
        return relative(self.root_frame_to_world, self.robot_base_group.pose)

    @property
    def leaf_frame_to_robot(self) -> np.ndarray:
        """Pose of the leaf frame in the robot frame (the root frame without a base), 4x4."""
        if self.robot_base_group is None:
            return self.leaf_frame_to_root
        return relative(self.leaf_frame_to_world, self.robot_base_group.pose)

    def get_jacobian(self) -> np.ndarray:
        """(6, nv) Jacobian of the leaf frame's origin w.r.t. all dofs: rows [linear (m/unit);
        angular (rad/unit)], world frame. Needs ``mj_kinematics`` + ``mj_comPos`` (or
        ``mj_forward``) for the current qpos."""
        return frame_jacobian(self.model, self.data, self.leaf_frame_type, self.leaf_frame_id)

    # -- data-explicit helpers -----------------------------------------------------------
    def get_qpos(self, data: mujoco.MjData) -> np.ndarray:
        """Joint positions, shape (pos_dim,) (a copy)."""
        return data.qpos[self._qpos_sel].copy()

    def set_qpos(self, data: mujoco.MjData, qpos: Sequence[float]) -> None:
        """Write the group's joint positions, (pos_dim,) rad / m, into ``data.qpos`` (a
        UserError for a wrong shape or NaN; run ``mj_kinematics`` / ``mj_forward`` after)."""
        q = np.asarray(qpos, dtype=float)
        if q.shape != (self.pos_dim,):
            raise UserError(f"{self.name}: expected {self.pos_dim} joint values, got {q.shape}")
        data.qpos[self.qpos_idx] = finite(self.name, q)

    def get_qvel(self, data: mujoco.MjData) -> np.ndarray:
        """Joint velocities (rad/s or m/s), shape (vel_dim,) (a copy)."""
        return data.qvel[self._dof_sel].copy()

    def set_qvel(self, data: mujoco.MjData, qvel: Sequence[float]) -> None:
        """Write the group's joint velocities, (vel_dim,) rad/s / m/s, into
        ``data.qvel`` (a UserError for a wrong shape or NaN)."""
        v = np.asarray(qvel, dtype=float)
        if v.shape != (self.vel_dim,):
            raise UserError(f"{self.name}: expected {self.vel_dim} joint velocities, got {v.shape}")
        data.qvel[self.dof_idx] = finite(self.name, v)

    def get_ctrl(self, data: mujoco.MjData) -> np.ndarray:
        """The control currently applied, shape (ctrl_dim,)."""
        return np.zeros(0)

    def set_ctrl(self, data: mujoco.MjData, ctrl: np.ndarray) -> None:
        """Write a control vector of shape (ctrl_dim,)."""
        if np.asarray(ctrl).size:
            raise UserError(f"move group '{self.name}' takes no control")

    def _write_ctrl(self, data: mujoco.MjData, ctrl: np.ndarray) -> None:
        """``set_ctrl`` for a control the robot layer computed itself: already of the right
        shape, finite and within ``ctrl_limits`` (controllers' ``limit`` makes it so), so
        nothing is checked again. Groups override it where that saves work."""
        self.set_ctrl(data, ctrl)

    def get_noop_ctrl(self, data: mujoco.MjData) -> np.ndarray:
        """A control that holds the current state."""
        return np.zeros(0)
