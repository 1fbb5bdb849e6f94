"""MJCFFrameMixin: a move group's leaf frame named in the MJCF, a site or a body.

An arm's tool frame (``ee_site``) is such a frame: its pose (``get_frame_pose``, [x, y, z,
qw, qx, qy, qz] in the world, m), its position (also as a live view), and its Jacobian
((6, nv), rows [linear; angular], world frame, via ``mj_jacSite`` / ``mj_jacBody``). Poses
and Jacobians read ``site_xpos``/``xpos``: valid after ``mj_kinematics`` / ``mj_forward``.
Mixed into the arm groups of ``arm_groups.py`` (before the move group class).

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.frames import frame_jacobian

__all__ = ["MJCFFrameMixin"]


class MJCFFrameMixin:
    """A leaf frame named in the MJCF: a site (e.g. the tool frame ``ee_site``) or a body.

    ``leaf_frame_id`` is its id, ``leaf_frame_type`` "site" or "body"; ``get_jacobian()``
    calls ``mj_jacSite`` or ``mj_jacBody`` accordingly.
    """

    # of the move group it is mixed into
    model: mujoco.MjModel
    data: mujoco.MjData
    name: str
    leaf_frame_id: int
    leaf_frame_type: str
    _qpos_sel: slice | np.ndarray
    _dof_sel: slice | np.ndarray

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
