"""Move groups: named sets of a robot's joints that are commanded together.

A move group owns the indices of its joints in ``qpos``/``qvel`` and of its actuators in
``ctrl`` (or its mocap body), looked up once from the model at construction. Built from an
``MjData`` (or bound later with ``bind``), it reads and writes that state through
properties: ``joint_pos``, ``joint_vel``, ``ctrl``, ``noop_ctrl``; its frames are 4x4
homogeneous transforms (``leaf_frame_to_world`` and friends, see ``frames.py``). Built from
an ``MjModel`` only, the data-explicit methods (``get_qpos(data)``, ...) still work.

Units: hinge joints in rad, slide joints (gripper fingers) in m; 7-value poses are
[x, y, z, qw, qx, qy, qz] in the world frame (m).

Frames: the *root frame* is the body the group's chain hangs from (the parent of its first
joint's body); the *leaf frame* is the body of its last joint, or the named site/body of an
``MJCFFrameMixin`` group (the tool frame ``ee_site`` of an arm). The *robot frame* is the
pose of the group's ``robot_base_group``; a group without one uses its root frame. Frames
and Jacobians read ``xpos``/``site_xpos``: valid after ``mj_kinematics``/``mj_forward``.

The gripper lives in ``gripper_group.py``, base groups (the robot frame itself) in
``base_group.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.binding import DataBound
from trossen_arm_mujoco.robot.checks import (
    check_velocity_limits,
    finite,
    model_and_data,
    vector,
)
from trossen_arm_mujoco.robot.frames import frame_jacobian, frame_transform, relative
from trossen_arm_mujoco.robot.limits import Limits, frozen
from trossen_arm_mujoco.robot.selection import as_slice

if TYPE_CHECKING:
    from trossen_arm_mujoco.robot.base_group import RobotBaseGroup

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
_BALL, _FREE = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)
_POS_DIM = {_FREE: 7, _BALL: 4, _SLIDE: 1, _HINGE: 1}
_VEL_DIM = {_FREE: 6, _BALL: 3, _SLIDE: 1, _HINGE: 1}


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
    joint_types: tuple[int, ...] = (_HINGE, _SLIDE)  # the joint types a group accepts

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
        self.joint_ids = np.array([lookup_id(model, "joint", j) for j in joint_names], dtype=int)
        posadr: list[int] = []
        veladr: list[int] = []
        limits: list[tuple[float, float]] = []
        for jid, jname in zip(self.joint_ids, self.joint_names):
            jtype = int(model.jnt_type[jid])
            if jtype not in self.joint_types:
                kinds = " or ".join(mujoco.mjtJoint(t).name[6:].lower() for t in self.joint_types)
                raise UserError(f"joint '{jname}' of move group '{name}' is not a {kinds}")
            npos, nvel = _POS_DIM[jtype], _VEL_DIM[jtype]
            posadr += range(int(model.jnt_qposadr[jid]), int(model.jnt_qposadr[jid]) + npos)
            veladr += range(int(model.jnt_dofadr[jid]), int(model.jnt_dofadr[jid]) + nvel)
            if npos == 1 and model.jnt_limited[jid]:
                limits.append(tuple(model.jnt_range[jid]))
            else:
                limits += [(-np.inf, np.inf)] * npos
        self.qpos_idx = np.array(posadr, dtype=int)
        self.dof_idx = np.array(veladr, dtype=int)
        # the same as slices where consecutive (cheaper to read through, every step)
        self._qpos_sel = as_slice(self.qpos_idx)
        self._dof_sel = as_slice(self.dof_idx)
        self.joint_range = np.array(limits, dtype=float).reshape(-1, 2)  # (pos_dim, 2)
        self.actuator_ids = np.zeros(0, dtype=int)
        self.velocity_limits: np.ndarray | None = None
        self._ctrl_low = self._ctrl_high = frozen(np.zeros(0))  # ctrl_limits, shared
        if isinstance(root_body, (int, np.integer)):
            self.root_body_id = int(root_body)
        elif root_body is not None:
            self.root_body_id = lookup_id(model, "body", root_body)
        elif len(self.joint_ids):
            self.root_body_id = int(model.body_parentid[model.jnt_bodyid[self.joint_ids[0]]])
        else:
            self.root_body_id = 0  # the world
        self.leaf_frame_type = "body"
        self.leaf_frame_id = (
            int(model.jnt_bodyid[self.joint_ids[-1]]) if len(self.joint_ids) else self.root_body_id
        )
        self.robot_base_group: RobotBaseGroup | None = None
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
    def ctrl_limits(self) -> Limits:
        """(ctrl_dim, 2) [low, high] per control value; ``ctrl_limits()`` gives (low, high)."""
        return Limits.of(self._ctrl_low, self._ctrl_high)

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
        q = np.asarray(qpos, dtype=float)
        if q.shape != (self.pos_dim,):
            raise UserError(f"{self.name}: expected {self.pos_dim} joint values, got {q.shape}")
        data.qpos[self.qpos_idx] = finite(self.name, q)

    def get_qvel(self, data: mujoco.MjData) -> np.ndarray:
        """Joint velocities (rad/s or m/s), shape (vel_dim,) (a copy)."""
        return data.qvel[self._dof_sel].copy()

    def set_qvel(self, data: mujoco.MjData, qvel: Sequence[float]) -> None:
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


class MJCFFrameMixin:
    """A leaf frame named in the MJCF: a site (e.g. the tool frame ``ee_site``) or a body.

    ``leaf_frame_id`` is its id, ``leaf_frame_type`` "site" or "body"; ``get_jacobian()``
    calls ``mj_jacSite`` or ``mj_jacBody`` accordingly.
    """

    model: mujoco.MjModel
    name: str
    leaf_frame_id: int
    leaf_frame_type: str

    def _init_frame(self, model: mujoco.MjModel, frame_name: str, frame_type: str = "site") -> None:
        if frame_type not in ("site", "body"):
            raise UserError(
                f"{self.name}: leaf frame type must be 'site' or 'body', got '{frame_type}'"
            )
        self.leaf_frame_type = frame_type
        self.leaf_frame_id = lookup_id(model, frame_type, frame_name)
        self.frame_name = frame_name
        self._site = frame_type == "site"
        # the tool-frame site of the IK controllers (plain attributes: read every step);
        # -1 / "" for a body frame, which ee_pose / ee_delta control refuses
        self.frame_site_id = self.leaf_frame_id if self._site else -1
        self.frame_site_name = frame_name if self._site else ""

    def get_jacobian(self) -> np.ndarray:
        """(6, nv) Jacobian of the leaf frame (site or body origin), rows [linear; angular],
        world frame (``mj_jacSite`` / ``mj_jacBody``; valid after ``mj_forward``)."""
        return self.get_frame_jacobian(self.model, self.data)

    def get_frame_pose(self, data: mujoco.MjData) -> np.ndarray:
        """World pose of the leaf frame, [x, y, z, qw, qx, qy, qz] (m)."""
        pose = np.empty(7)
        if self._site:
            pose[:3] = data.site_xpos[self.leaf_frame_id]
            mujoco.mju_mat2Quat(pose[3:], data.site_xmat[self.leaf_frame_id])
        else:
            pose[:3] = data.xpos[self.leaf_frame_id]
            pose[3:] = data.xquat[self.leaf_frame_id]
        return pose

    def get_frame_position(self, data: mujoco.MjData) -> np.ndarray:
        """World position of the leaf frame, [x, y, z] (m): ``get_frame_pose(data)[:3]``
        without working out the orientation."""
        return self.frame_position_view(data).copy()

    def frame_position_view(self, data: mujoco.MjData) -> np.ndarray:
        """``get_frame_position`` as a live view of ``data`` (3,) m: it follows the
        simulation; read it, never write it."""
        xpos = data.site_xpos if self._site else data.xpos
        return xpos[self.leaf_frame_id]

    def state_views(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray] | None:
        """Live views of the joint positions (pos_dim,) and velocities (vel_dim,) in ``data``
        (they follow the simulation; read them, never write them), or None when the joints
        are not consecutive in ``qpos``/``qvel`` (use ``get_qpos``/``get_qvel``)."""
        if isinstance(self._qpos_sel, slice) and isinstance(self._dof_sel, slice):
            return data.qpos[self._qpos_sel], data.qvel[self._dof_sel]
        return None

    def get_frame_jacobian(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Jacobian of the leaf frame w.r.t. all dofs, shape (6, nv): rows [linear; angular],
        world frame. Valid after ``mj_kinematics`` + ``mj_comPos`` for the current qpos."""
        return frame_jacobian(model, data, self.leaf_frame_type, self.leaf_frame_id)


class SimplyActuatedMoveGroup(MoveGroup):
    """One position actuator per joint: the control is the joint target (rad or m).

    ``joint_ids``, ``actuator_ids``, ``joint_posadr``, ``joint_veladr``: model indices.
    """

    rate_limitable = True

    def __init__(self, model, name, joint_names, actuator_names: Sequence[str]):
        super().__init__(model, name, joint_names)
        if len(actuator_names) != len(joint_names):
            raise UserError(f"{name}: one actuator per joint is required")
        self.actuator_ids = np.array(
            [lookup_id(self.model, "actuator", a) for a in actuator_names], dtype=int
        )
        self._ctrl_range = self.model.actuator_ctrlrange[self.actuator_ids].copy()
        self._ctrl_low, self._ctrl_high = (
            frozen(self._ctrl_range[:, 0]),
            frozen(self._ctrl_range[:, 1]),
        )
        self._ctrl_sel = as_slice(self.actuator_ids)

    @property
    def ctrl_dim(self) -> int:
        return len(self.actuator_ids)

    def get_ctrl(self, data):
        return data.ctrl[self._ctrl_sel].copy()

    def set_ctrl(self, data, ctrl):
        c = vector(self.name, ctrl, self.ctrl_dim)
        data.ctrl[self.actuator_ids] = clip(c, self._ctrl_low, self._ctrl_high)

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self._ctrl_sel] = ctrl

    def get_noop_ctrl(self, data):
        return self.get_qpos(data)


class ArmMoveGroup(MJCFFrameMixin, SimplyActuatedMoveGroup):
    """A joint-actuated arm with a tool frame (a site, or a body with ``frame_type="body"``)."""

    def __init__(
        self, model, name, joint_names, actuator_names, frame_site: str, frame_type: str = "site"
    ):
        super().__init__(model, name, joint_names, actuator_names)
        self._init_frame(self.model, frame_site, frame_type)


class MocapArmGroup(MJCFFrameMixin, MoveGroup):
    """An arm driven by a mocap body welded to its last link.

    The control is the mocap pose [x, y, z, qw, qx, qy, qz] (world frame, m); the weld pulls
    the arm's tool frame onto it. qpos/qvel are the arm's joints.
    """

    def __init__(self, model, name, joint_names, mocap_body: str, frame_site: str):
        super().__init__(model, name, joint_names)
        body_id = lookup_id(self.model, "body", mocap_body)
        self.mocap_id = int(self.model.body_mocapid[body_id])
        if self.mocap_id < 0:
            raise UserError(f"{name}: body '{mocap_body}' is not a mocap body")
        self._init_frame(self.model, frame_site)
        self._ctrl_low = frozen(np.array([-2.0, -2.0, -2.0, -1, -1, -1, -1]))
        self._ctrl_high = frozen(np.array([2.0, 2.0, 2.0, 1, 1, 1, 1]))

    @property
    def ctrl_dim(self) -> int:
        return 7

    def get_ctrl(self, data):
        return np.concatenate([data.mocap_pos[self.mocap_id], data.mocap_quat[self.mocap_id]])

    def set_ctrl(self, data, ctrl):
        c = vector(self.name, ctrl, 7)
        norm = np.linalg.norm(c[3:])
        if norm < 1e-9:
            raise UserError(f"{self.name}: mocap quaternion has zero length")
        data.mocap_pos[self.mocap_id] = c[:3]
        data.mocap_quat[self.mocap_id] = c[3:] / norm

    def get_noop_ctrl(self, data):
        return self.get_ctrl(data)


def __getattr__(name: str):
    """Earlier import paths of the gripper and base groups (``gripper_group.py``,
    ``base_group.py``): ``from ...move_group import GripperGroup, ImmobileBaseGroup``."""
    if name == "GripperGroup":
        from trossen_arm_mujoco.robot.gripper_group import GripperGroup

        return GripperGroup
    if name in ("ImmobileBaseGroup", "ImmobileRobotBaseGroup", "RobotBaseGroup"):
        from trossen_arm_mujoco.robot import base_group

        return getattr(base_group, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
