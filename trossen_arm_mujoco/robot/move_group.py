"""Move groups: named sets of a robot's joints that are commanded together.

A move group owns the indices of its joints in ``qpos``/``qvel`` and of its actuators in
``ctrl`` (or its mocap body), looked up once from the model at construction. Units: hinge
joints in rad, slide joints (gripper fingers) in m; poses are [x, y, z, qw, qx, qy, qz] in
the world frame (m).
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id


def _vector(name: str, value, size: int) -> np.ndarray:
    """``value`` as a finite float vector of ``size`` values, else a one-line UserError."""
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise UserError(f"{name}: expected {size} control values, got {v.size}")
    return _finite(name, v)


def _finite(name: str, value: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(value)):
        raise UserError(f"{name}: command contains NaN or inf: {np.round(value, 4).tolist()}")
    return value


def check_velocity_limits(name: str, limits: Sequence[float], size: int) -> np.ndarray:
    """``limits`` as a (size,) array of positive, finite speeds, else a one-line UserError.

    Args:
        name: move group name, for the message.
        limits: max speed per control value (rad/s for hinge joints, m/s for slide joints).
        size: the group's number of control values.
    """
    v = np.asarray(limits, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise UserError(
            f"{name}: expected {size} velocity limits (one per control value), got {v.size}"
        )
    if not np.all(np.isfinite(v) & (v > 0)):
        raise UserError(f"{name}: velocity limits must be positive and finite, got {v.tolist()}")
    return v


def _frozen(values) -> np.ndarray:
    """A read-only float copy (limits shared by the hot paths, never handed out)."""
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out


class MoveGroup:
    """Joints of one robot that move together.

    Args:
        model: compiled MuJoCo model.
        name: group name (e.g. "left_arm").
        joint_names: 1-dof joints (hinge or slide) of the group, in command order.

    ``velocity_limits`` (None or (ctrl_dim,), rad/s or m/s) is the speed that joint-position
    controllers hold the group's control to; see ``set_velocity_limits``.
    """

    rate_limitable = False  # whether the control is joint positions that velocity limits fit

    def __init__(self, model: mujoco.MjModel, name: str, joint_names: Sequence[str]):
        self.name = name
        self.joint_names = list(joint_names)
        self.joint_ids = np.array([lookup_id(model, "joint", j) for j in joint_names], dtype=int)
        for jid, jname in zip(self.joint_ids, self.joint_names):
            if int(model.jnt_type[jid]) not in (
                int(mujoco.mjtJoint.mjJNT_HINGE),
                int(mujoco.mjtJoint.mjJNT_SLIDE),
            ):
                raise UserError(f"joint '{jname}' of move group '{name}' is not a hinge or slide")
        self.qpos_idx = model.jnt_qposadr[self.joint_ids].astype(int)
        self.dof_idx = model.jnt_dofadr[self.joint_ids].astype(int)
        self.joint_range = model.jnt_range[self.joint_ids].copy()  # (n, 2)
        self.velocity_limits: np.ndarray | None = None
        self._ctrl_low = self._ctrl_high = _frozen(np.zeros(0))  # ctrl_limits(), shared

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
    def ctrl_dim(self) -> int:
        """Length of this group's control vector (0 for groups that cannot move)."""
        return 0

    def get_qpos(self, data: mujoco.MjData) -> np.ndarray:
        """Joint positions, shape (n_joints,)."""
        return data.qpos[self.qpos_idx].copy()

    def set_qpos(self, data: mujoco.MjData, qpos: Sequence[float]) -> None:
        q = np.asarray(qpos, dtype=float)
        if q.shape != (self.n_joints,):
            raise UserError(f"{self.name}: expected {self.n_joints} joint values, got {q.shape}")
        data.qpos[self.qpos_idx] = _finite(self.name, q)

    def get_qvel(self, data: mujoco.MjData) -> np.ndarray:
        """Joint velocities (rad/s or m/s), shape (n_joints,)."""
        return data.qvel[self.dof_idx].copy()

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

    def ctrl_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the control vector, each (ctrl_dim,)."""
        return np.zeros(0), np.zeros(0)


class MJCFFrameMixin:
    """Pose and Jacobian of one MJCF site (the group's tool frame, e.g. ``ee_site``)."""

    frame_site_id: int

    def _init_frame(self, model: mujoco.MjModel, site_name: str) -> None:
        self.frame_site_name = site_name
        self.frame_site_id = lookup_id(model, "site", site_name)

    def get_frame_pose(self, data: mujoco.MjData) -> np.ndarray:
        """World pose of the frame site, [x, y, z, qw, qx, qy, qz] (m)."""
        pose = np.empty(7)
        pose[:3] = data.site_xpos[self.frame_site_id]
        mujoco.mju_mat2Quat(pose[3:], data.site_xmat[self.frame_site_id])
        return pose

    def get_frame_position(self, data: mujoco.MjData) -> np.ndarray:
        """World position of the frame site, [x, y, z] (m): ``get_frame_pose(data)[:3]``
        without working out the orientation."""
        return data.site_xpos[self.frame_site_id].copy()

    def get_frame_jacobian(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Jacobian of the frame site w.r.t. all dofs, shape (6, nv): rows [linear; angular],
        world frame. Valid after ``mj_kinematics``/``mj_forward`` for the current qpos."""
        jac = np.zeros((6, model.nv))
        mujoco.mj_jacSite(model, data, jac[:3], jac[3:], self.frame_site_id)
        return jac


class SimplyActuatedMoveGroup(MoveGroup):
    """One position actuator per joint: the control is the joint target (rad or m)."""

    rate_limitable = True

    def __init__(self, model, name, joint_names, actuator_names: Sequence[str]):
        super().__init__(model, name, joint_names)
        if len(actuator_names) != len(joint_names):
            raise UserError(f"{name}: one actuator per joint is required")
        self.actuator_ids = np.array([lookup_id(model, "actuator", a) for a in actuator_names])
        self._ctrl_range = model.actuator_ctrlrange[self.actuator_ids].copy()
        self._ctrl_low, self._ctrl_high = (
            _frozen(self._ctrl_range[:, 0]),
            _frozen(self._ctrl_range[:, 1]),
        )
        ids = self.actuator_ids
        contiguous = len(ids) > 0 and np.array_equal(ids, np.arange(ids[0], ids[0] + len(ids)))
        self._ctrl_sel = slice(int(ids[0]), int(ids[0]) + len(ids)) if contiguous else ids

    @property
    def ctrl_dim(self) -> int:
        return len(self.actuator_ids)

    def get_ctrl(self, data):
        return data.ctrl[self._ctrl_sel].copy()

    def set_ctrl(self, data, ctrl):
        c = _vector(self.name, ctrl, self.ctrl_dim)
        data.ctrl[self.actuator_ids] = np.clip(c, self._ctrl_range[:, 0], self._ctrl_range[:, 1])

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self._ctrl_sel] = ctrl

    def get_noop_ctrl(self, data):
        return self.get_qpos(data)

    def ctrl_limits(self):
        return self._ctrl_range[:, 0].copy(), self._ctrl_range[:, 1].copy()


class ArmMoveGroup(MJCFFrameMixin, SimplyActuatedMoveGroup):
    """A joint-actuated arm with a tool frame site."""

    def __init__(self, model, name, joint_names, actuator_names, frame_site: str):
        super().__init__(model, name, joint_names, actuator_names)
        self._init_frame(model, frame_site)


class GripperGroup(MoveGroup):
    """Two coupled fingers driven by one position actuator.

    qpos has both finger joints (m, 0 closed to 0.044 open); the control is one value: the
    target travel of the actuated finger (m).
    """

    rate_limitable = True

    def __init__(self, model, name, joint_names, actuator_name: str):
        super().__init__(model, name, joint_names)
        self.actuator_id = lookup_id(model, "actuator", actuator_name)
        joint_of_actuator = int(model.actuator_trnid[self.actuator_id, 0])
        if joint_of_actuator not in self.joint_ids:
            raise UserError(f"{name}: actuator '{actuator_name}' drives none of {joint_names}")
        self.actuated_qpos_idx = int(model.jnt_qposadr[joint_of_actuator])
        self._ctrl_range = model.actuator_ctrlrange[self.actuator_id].copy()
        self._ctrl_low, self._ctrl_high = (
            _frozen(self._ctrl_range[:1]),
            _frozen(self._ctrl_range[1:]),
        )

    @property
    def ctrl_dim(self) -> int:
        return 1

    def get_ctrl(self, data):
        return data.ctrl[[self.actuator_id]].copy()

    def set_ctrl(self, data, ctrl):
        c = _vector(self.name, ctrl, 1)
        data.ctrl[self.actuator_id] = np.clip(c[0], *self._ctrl_range)

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self.actuator_id] = ctrl[0]

    def get_noop_ctrl(self, data):
        return np.array([data.qpos[self.actuated_qpos_idx]])

    def ctrl_limits(self):
        return self._ctrl_range[:1].copy(), self._ctrl_range[1:].copy()


class MocapArmGroup(MJCFFrameMixin, MoveGroup):
    """An arm driven by a mocap body welded to its last link.

    The control is the mocap pose [x, y, z, qw, qx, qy, qz] (world frame, m); the weld pulls
    the arm's tool frame onto it. qpos/qvel are the arm's joints.
    """

    def __init__(self, model, name, joint_names, mocap_body: str, frame_site: str):
        super().__init__(model, name, joint_names)
        body_id = lookup_id(model, "body", mocap_body)
        self.mocap_id = int(model.body_mocapid[body_id])
        if self.mocap_id < 0:
            raise UserError(f"{name}: body '{mocap_body}' is not a mocap body")
        self._init_frame(model, frame_site)
        self._ctrl_low = _frozen(np.array([-2.0, -2.0, -2.0, -1, -1, -1, -1]))
        self._ctrl_high = _frozen(np.array([2.0, 2.0, 2.0, 1, 1, 1, 1]))

    @property
    def ctrl_dim(self) -> int:
        return 7

    def get_ctrl(self, data):
        return np.concatenate([data.mocap_pos[self.mocap_id], data.mocap_quat[self.mocap_id]])

    def set_ctrl(self, data, ctrl):
        c = _vector(self.name, ctrl, 7)
        norm = np.linalg.norm(c[3:])
        if norm < 1e-9:
            raise UserError(f"{self.name}: mocap quaternion has zero length")
        data.mocap_pos[self.mocap_id] = c[:3]
        data.mocap_quat[self.mocap_id] = c[3:] / norm

    def get_noop_ctrl(self, data):
        return self.get_ctrl(data)

    def ctrl_limits(self):
        return self._ctrl_low.copy(), self._ctrl_high.copy()


class ImmobileBaseGroup(MoveGroup):
    """A robot base fixed to the world: no joints, no control, only a pose."""

    def __init__(self, model, name, base_body: str):
        super().__init__(model, name, [])
        self.body_id = lookup_id(model, "body", base_body)

    def get_pose(self, data: mujoco.MjData) -> np.ndarray:
        """World pose of the base body, [x, y, z, qw, qx, qy, qz]."""
        return np.concatenate([data.xpos[self.body_id], data.xquat[self.body_id]])
