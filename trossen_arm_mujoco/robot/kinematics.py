"""Forward kinematics and differential inverse kinematics on a scratch copy of the state.

Nothing here steps physics or writes the caller's ``MjData``: a private ``MjData`` is used
for every evaluation. Poses are [x, y, z, qw, qx, qy, qz] in the world frame (m).

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError

__all__ = ["Kinematics", "damped_least_squares", "orientation_error"]


def orientation_error(target_quat: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """Rotation vector (rad, world frame) that turns ``quat`` into ``target_quat``."""
    conj = np.zeros(4)
    mujoco.mju_negQuat(conj, quat)
    err_q = np.zeros(4)
    mujoco.mju_mulQuat(err_q, target_quat, conj)
    if err_q[0] < 0:  # shortest way round
        err_q = -err_q
    vel = np.zeros(3)
    mujoco.mju_quat2Vel(vel, err_q, 1.0)
    return vel


def damped_least_squares(jac: np.ndarray, err: np.ndarray, damping: float = 1e-3) -> np.ndarray:
    """dq = J^T (J J^T + damping^2 I)^-1 err.

    J J^T + damping^2 I is symmetric positive definite for damping > 0: solved by MuJoCo's
    Cholesky (a fraction of ``np.linalg.solve``'s overhead at these sizes); LU otherwise.

    Args:
        jac: (m, n) Jacobian.
        err: (m,) task-space error.
        damping: the damping factor (> 0: Cholesky; 0: LU).

    Returns:
        (n,) the joint step dq.
    """
    a = jac @ jac.T
    m = a.shape[0]
    a.flat[:: m + 1] += damping**2
    rhs = np.ascontiguousarray(err, dtype=float)
    if damping > 0 and mujoco.mju_cholFactor(a, 0.0) == m:
        x = np.empty(m)
        mujoco.mju_cholSolve(x, a, rhs)
        return jac.T @ x
    jjt = jac @ jac.T
    return jac.T @ np.linalg.solve(jjt + damping**2 * np.eye(m), rhs)


class Kinematics:
    """FK and IK of one site over the joints given by their qpos/dof indices.

    Args:
        model: compiled model.
        site_id: id of the tool-frame site.
        qpos_idx, dof_idx: indices of the (1-dof) joints that IK may move.
        joint_range: (n, 2) limits of those joints.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        site_id: int,
        qpos_idx: Sequence[int],
        dof_idx: Sequence[int],
        joint_range: np.ndarray,
    ):
        if site_id < 0:
            raise UserError(
                "IK needs a site as the tool frame (the move group's leaf frame is a body); "
                "name a site as its frame"
            )
        self.model = model
        self.site_id = site_id
        self.qpos_idx = np.asarray(qpos_idx, dtype=int)
        self.dof_idx = np.asarray(dof_idx, dtype=int)
        self.joint_range = np.asarray(joint_range, dtype=float)
        self._low = self.joint_range[:, 0].copy()
        self._high = self.joint_range[:, 1].copy()
        self._data = mujoco.MjData(model)
        #: (qpos, twist, damping, result) of the last ``delta_step``
        self._delta_memo: tuple[np.ndarray, np.ndarray, float, np.ndarray] | None = None

    def _load(self, qpos_full: np.ndarray, q: np.ndarray | None = None, com: bool = True) -> None:
        """Scratch state at ``qpos_full`` (group joints replaced by ``q``): kinematics, and
        with ``com`` the COM-based quantities Jacobians need."""
        self._data.qpos[:] = qpos_full
        if q is not None:
            self._data.qpos[self.qpos_idx] = q
        mujoco.mj_kinematics(self.model, self._data)
        if com:
            mujoco.mj_comPos(self.model, self._data)

    def site_pose(self, qpos_full: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Site pose for the full qpos (nq,), optionally with the group joints replaced by q."""
        self._load(qpos_full, q, com=False)
        pose = np.empty(7)
        pose[:3] = self._data.site_xpos[self.site_id]
        mujoco.mju_mat2Quat(pose[3:], self._data.site_xmat[self.site_id])
        return pose

    def site_position(self, qpos_full: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Site position (3,) m, world frame; as ``site_pose`` without the orientation."""
        self._load(qpos_full, q, com=False)
        return self._data.site_xpos[self.site_id].copy()

    def jacobian(self, qpos_full: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Site Jacobian (6, n) w.r.t. the group joints, rows [linear; angular], world frame."""
        self._load(qpos_full, q)
        jac = np.zeros((6, self.model.nv))
        mujoco.mj_jacSite(self.model, self._data, jac[:3], jac[3:], self.site_id)
        return jac[:, self.dof_idx]

    def delta_step(
        self, qpos_full: np.ndarray, twist: np.ndarray, damping: float = 1e-3
    ) -> np.ndarray:
        """Joint targets after one differential-IK step toward a Cartesian delta.

        Args:
            twist: (3,) position delta (m) or (6,) [position delta (m), rotation vector (rad)],
                world frame.
        Returns:
            (n,) joint positions, clipped to the joint limits (a new array).

        The last result is kept: asked again for the same qpos, twist and damping (a safety
        check predicting the step, then the controller taking it), it is returned without
        solving again.
        """
        twist = np.asarray(twist, dtype=float)
        if twist.shape not in ((3,), (6,)):
            raise ValueError(f"twist must have 3 or 6 values, got shape {twist.shape}")
        memo = self._delta_memo
        if (
            memo is not None
            and memo[2] == damping
            and memo[1].shape == twist.shape
            and (memo[1] == twist).all()
            and (memo[0] == qpos_full).all()
        ):
            return memo[3].copy()
        q = qpos_full[self.qpos_idx]  # a copy (fancy indexing)
        self._load(qpos_full)
        jac = np.zeros((len(twist), self.model.nv))
        rot = jac[3:] if len(twist) == 6 else None
        mujoco.mj_jacSite(self.model, self._data, jac[:3], rot, self.site_id)
        dq = damped_least_squares(jac[:, self.dof_idx], twist, damping)
        out = clip(q + dq, self._low, self._high)
        self._delta_memo = (np.array(qpos_full, dtype=float), twist.copy(), damping, out.copy())
        return out

    def solve(
        self,
        qpos_full: np.ndarray,
        target_pos: np.ndarray,
        target_quat: np.ndarray | None = None,
        iterations: int = 100,
        tol: float = 1e-6,
        damping: float = 1e-3,
        max_step: float = 0.2,
    ) -> tuple[np.ndarray, float]:
        """Iterative IK from the current joints toward a pose (orientation optional).

        Args:
            qpos_full: (nq,) the model's full joint positions; the chain's are the start.
            target_pos: (3,) the frame's target position, world frame (m).
            target_quat: (4,) the target orientation, quaternion wxyz; None: position only.
            iterations: the most iterations.
            tol: stop once the error norm is below this (m, plus rad).
            damping: damped least squares factor.
            max_step: the largest joint step per iteration (rad).

        Returns:
            (q (n,), residual): joint solution within limits and the final error norm
            (m, plus rad when an orientation is given).
        """
        q = qpos_full[self.qpos_idx].copy()
        err_norm = np.inf
        for _ in range(iterations):
            pose = self.site_pose(qpos_full, q)
            err = np.asarray(target_pos, float) - pose[:3]
            if target_quat is not None:
                err = np.concatenate([err, orientation_error(np.asarray(target_quat), pose[3:])])
            err_norm = float(np.linalg.norm(err))
            if err_norm < tol:
                break
            jac = self.jacobian(qpos_full, q)[: len(err)]
            dq = damped_least_squares(jac, err, damping)
            scale = max(1.0, np.abs(dq).max() / max_step)
            q = np.clip(q + dq / scale, self.joint_range[:, 0], self.joint_range[:, 1])
        return q, err_norm
