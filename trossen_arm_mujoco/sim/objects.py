"""Free-joint objects (e.g. the cube): pose get/set by name, looked up once.

Docs: docs/reference/robot-sim.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id

__all__ = ["FreeJointObject"]


def _object_geom(
    model: mujoco.MjModel, joint_name: str, body_id: int, geom_name: str | None
) -> int | None:
    """The id of ``geom_name``, a geom of the free joint's body (None when not given); a
    body's name given in its place, or a geom of another body, is a one-line UserError."""
    if not geom_name:
        return None
    body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body_id)
    own = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"#{g}"
        for g in range(model.ngeom)
        if int(model.geom_bodyid[g]) == body_id
    ]
    geom_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom_name)
    if geom_id < 0 and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, geom_name) >= 0:
        raise UserError(
            f"'{geom_name}' is a body, not a geom: an object is (free joint, geom); "
            f"the geoms of body '{body}': {', '.join(own) or 'none'}"
        )
    geom_id = lookup_id(model, "geom", geom_name)
    if int(model.geom_bodyid[geom_id]) != body_id:
        raise UserError(
            f"geom '{geom_name}' is not on body '{body}', the body of free joint "
            f"'{joint_name}': give one of its geoms: {', '.join(own) or 'none'}"
        )
    return geom_id


class FreeJointObject:
    """A body with a free joint. Pose = [x, y, z, qw, qx, qy, qz] (world, m).

    Args:
        model: compiled model.
        joint_name: the free joint.
        geom_name: a geom of the joint's body (the object's contact geom); None: none.

    Raises:
        UserError: not a free joint, or a geom not on its body.
    """

    def __init__(self, model: mujoco.MjModel, joint_name: str, geom_name: str | None = None):
        self.joint_name = joint_name
        self.joint_id = lookup_id(model, "joint", joint_name)
        if int(model.jnt_type[self.joint_id]) != int(mujoco.mjtJoint.mjJNT_FREE):
            raise UserError(f"joint '{joint_name}' is not a free joint")
        self.qpos_adr = int(model.jnt_qposadr[self.joint_id])
        self.dof_adr = int(model.jnt_dofadr[self.joint_id])
        self.body_id = int(model.jnt_bodyid[self.joint_id])
        self.geom_id = _object_geom(model, joint_name, self.body_id, geom_name)

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
