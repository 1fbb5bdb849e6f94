"""Free-joint objects (e.g. the cube): pose get/set by name, looked up once."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id

__all__ = ["FreeJointObject"]


class FreeJointObject:
    """A body with a free joint. Pose = [x, y, z, qw, qx, qy, qz] (world, m)."""

    def __init__(self, model: mujoco.MjModel, joint_name: str, geom_name: str | None = None):
        self.joint_name = joint_name
        self.joint_id = lookup_id(model, "joint", joint_name)
        if int(model.jnt_type[self.joint_id]) != int(mujoco.mjtJoint.mjJNT_FREE):
            raise UserError(f"joint '{joint_name}' is not a free joint")
        self.qpos_adr = int(model.jnt_qposadr[self.joint_id])
        self.dof_adr = int(model.jnt_dofadr[self.joint_id])
        self.body_id = int(model.jnt_bodyid[self.joint_id])
        self.geom_id = lookup_id(model, "geom", geom_name) if geom_name else None

    def get_pose(self, data: mujoco.MjData) -> np.ndarray:
        """The object's pose, (7,) [x, y, z (m, world frame), quat wxyz], a copy."""
        return self.pose_view(data).copy()

    def pose_view(self, data: mujoco.MjData) -> np.ndarray:
        """``get_pose`` as a live view of ``data.qpos`` (7,): it follows the simulation;
        read it, never write it (``set_pose`` normalizes and zeroes the velocity)."""
        return data.qpos[self.qpos_adr : self.qpos_adr + 7]

    def set_pose(self, data: mujoco.MjData, pose: Sequence[float]) -> None:
        """Place the object and zero its velocity (call mj_forward afterwards)."""
        p = np.asarray(pose, dtype=float)
        if p.shape != (7,) or not np.all(np.isfinite(p)) or np.linalg.norm(p[3:]) < 1e-9:
            raise UserError(f"{self.joint_name}: pose must be 7 finite values [xyz, quat wxyz]")
        p[3:] /= np.linalg.norm(p[3:])
        data.qpos[self.qpos_adr : self.qpos_adr + 7] = p
        self.zero_velocity(data)

    def zero_velocity(self, data: mujoco.MjData) -> None:
        """Set the free joint's 6 velocities (linear m/s, angular rad/s) to zero."""
        data.qvel[self.dof_adr : self.dof_adr + 6] = 0.0

    def get_velocity(self, data: mujoco.MjData) -> np.ndarray:
        """[linear (m/s), angular (rad/s)] velocity, shape (6,)."""
        return self.velocity_view(data).copy()

    def velocity_view(self, data: mujoco.MjData) -> np.ndarray:
        """``get_velocity`` as a live view of ``data.qvel`` (6,); read it, never write it."""
        return data.qvel[self.dof_adr : self.dof_adr + 6]
