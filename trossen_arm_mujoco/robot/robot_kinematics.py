"""RobotKinematics: forward and inverse kinematics of a whole robot, on a private MjData.

Nothing here steps physics or writes the caller's ``MjData``. Every call starts from a
*reference state* (the robot's live ``MjData`` when the robot is bound to one, else the
model's ``qpos0`` and mocap poses) and replaces the joints of the groups it is given.

Poses are 4x4 homogeneous transforms (``frames.py``; 7 values [x, y, z, qw, qx, qy, qz]
are accepted as input). World poses by default; ``base_pose`` puts the robot's primary base
(its first base group) somewhere else (other bases keep their placement relative to it);
``rel_to_base`` gives or takes poses in each group's robot frame (``leaf_frame_to_robot``).

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.frames import as_transform, invert, pose_error
from trossen_arm_mujoco.robot.kinematics import damped_least_squares
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.robot_view import RobotView

__all__ = ["IKResult", "RobotKinematics", "check_ik_options"]

if TYPE_CHECKING:
    from trossen_arm_mujoco.robot.configs import RobotConfig

_HINGE_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass(frozen=True)
class IKResult:
    """What an IK solve found.

    qpos: joint positions of every group with joints (rad / m), the unlocked ones solved.
    residual: norm of the final pose error [position (m); rotation vector (rad)].
    iterations: update steps taken.
    converged: ``residual < eps``.
    """

    qpos: dict[str, np.ndarray]
    residual: float
    iterations: int
    converged: bool


def check_ik_options(eps: float, max_iter: int, damping: float, max_step: float) -> None:
    """One-line UserErrors for IK options out of range.

    Args:
        eps: convergence tolerance of the pose error (> 0).
        max_iter: the most iterations (>= 1).
        damping: damped least squares factor (>= 0).
        max_step: the largest joint step per iteration (> 0, rad).
    """
    if not (np.isfinite(eps) and eps >= 0):
        raise UserError(f"IK eps must be a finite number >= 0, got {eps}")
    if int(max_iter) != max_iter or max_iter < 0:
        raise UserError(f"IK max_iter must be a whole number >= 0, got {max_iter}")
    if not (np.isfinite(damping) and damping > 0):
        raise UserError(f"IK damping must be a positive number, got {damping}")
    if not (np.isfinite(max_step) and max_step > 0):
        raise UserError(f"IK max_step must be a positive number (rad or m), got {max_step}")


class RobotKinematics:
    """FK of every move group's leaf frame, and damped-least-squares IK of one group.

    Args:
        model: compiled model.
        config: the robot's config (its view is rebuilt on a private ``MjData``).
        reference: a robot view whose bound data is the reference state (``Robot`` passes
            its own); None or unbound: the model's defaults.
    """

    def __init__(
        self, model: mujoco.MjModel, config: RobotConfig, reference: RobotView | None = None
    ):
        self.model = model
        self.config = config
        self.data = mujoco.MjData(model)
        self.robot_view: RobotView = config.build_view(self.data)
        self.reference = reference
        self._default = (
            self.data.qpos.copy(),
            self.data.mocap_pos.copy(),
            self.data.mocap_quat.copy(),
        )

    # -- state ---------------------------------------------------------------------------
    def reference_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(qpos (nq,), mocap_pos (nmocap, 3), mocap_quat (nmocap, 4)) calls start from."""
        ref = self.reference
        if ref is not None and ref.is_bound:
            return ref.data.qpos, ref.data.mocap_pos, ref.data.mocap_quat
        return self._default

    def load(self, qpos_dict: Mapping[str, Sequence[float]] | None = None) -> None:
        """Private state := reference state with the groups of ``qpos_dict`` replaced;
        kinematics and COM quantities computed (frames and Jacobians valid)."""
        qpos, mocap_pos, mocap_quat = self.reference_state()
        data = self.data
        data.qpos[:] = qpos
        data.mocap_pos[:] = mocap_pos
        data.mocap_quat[:] = mocap_quat
        if qpos_dict:
            self.robot_view.set_qpos_dict(qpos_dict)
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)

    def base_correction(self, base_pose) -> np.ndarray:
        """4x4 ``base_pose @ inv(primary base pose now)``: maps world poses of the loaded
        state to world poses with the primary base at ``base_pose``."""
        placed = as_transform("base pose", base_pose)
        return placed @ invert(self.robot_view.base.pose)

    def world_target(
        self, group: MoveGroup, pose, base_pose=None, rel_to_base: bool = False
    ) -> np.ndarray:
        """An IK target as a world pose of the loaded state (4x4).

        Args:
            group: the move group whose leaf frame is aimed.
            pose: the target, 4x4 or 7 values [x, y, z, qw, qx, qy, qz] (m).
            base_pose: the robot base's world pose to use; None: the loaded state's.
            rel_to_base: ``pose`` is in the robot frame, not the world.
        """
        target = as_transform("IK target pose", pose)
        if rel_to_base:
            base = group.robot_base_group
            return (base.pose if base is not None else group.root_frame_to_world) @ target
        if base_pose is not None:
            return invert(self.base_correction(base_pose)) @ target
        return target

    # -- forward kinematics ---------------------------------------------------------------
    def fk(
        self,
        qpos_dict: Mapping[str, Sequence[float]] | None = None,
        base_pose=None,
        rel_to_base: bool = False,
    ) -> dict[str, np.ndarray]:
        """Leaf-frame pose of every move group, group id -> 4x4.

        Args:
            qpos_dict: joint positions per group id (rad / m); missing groups keep the
                reference state.
            base_pose: world pose of the primary base (4x4 or 7 values); default where it is.
            rel_to_base: poses in each group's robot frame instead of the world.
        """
        self.load(qpos_dict)
        groups = self.robot_view.move_groups
        if rel_to_base:
            return {n: g.leaf_frame_to_robot for n, g in groups.items()}
        if base_pose is None:
            return {n: g.leaf_frame_to_world for n, g in groups.items()}
        correction = self.base_correction(base_pose)
        return {n: correction @ g.leaf_frame_to_world for n, g in groups.items()}

    # -- inverse kinematics ---------------------------------------------------------------
    def unlocked_indices(self, unlocked: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """(qpos indices, (n, 2) limits) of the joints IK may move; hinge and slide only."""
        view = self.robot_view
        for name in unlocked:
            group = view.get_move_group(name)
            types = {int(self.model.jnt_type[j]) for j in group.joint_ids}
            if not types <= set(_HINGE_SLIDE):
                raise UserError(
                    f"IK moves hinge and slide joints; move group '{name}' has other joints "
                    "(lock it: leave it out of unlocked_move_group_ids)"
                )
        posadr = view.qpos_indices(unlocked)
        if posadr.size == 0:
            raise UserError(f"IK has no joints to move: unlocked groups {unlocked} have none")
        limits = [view.get_move_group(n).joint_range for n in unlocked]
        return posadr, np.concatenate(limits).reshape(-1, 2)

    def ik(
        self, move_group_id: str, pose, *args: Any, **kwargs: Any
    ) -> dict[str, np.ndarray] | None:
        """Joint positions that put ``move_group_id``'s leaf frame at ``pose``.

        Args:
            move_group_id: the group whose leaf frame is aimed.
            pose: the target, 4x4 or 7 values [x, y, z, qw, qx, qy, qz] (m).
            *args: as for ``solve_ik``.
            **kwargs: as for ``solve_ik`` (``unlocked_move_group_ids``, ``q0``,
                ``base_pose``, ``rel_to_base``, ``eps``, ``max_iter``, ``damping``,
                ``max_step``).

        Returns:
            Move group id -> joint positions, or None when the solve does not converge.
        """
        result = self.solve_ik(move_group_id, pose, *args, **kwargs)
        return result.qpos if result.converged else None

    def solve_ik(
        self,
        move_group_id: str,
        pose,
        unlocked_move_group_ids: Sequence[str] | None = None,
        q0: Mapping[str, Sequence[float]] | None = None,
        base_pose=None,
        rel_to_base: bool = False,
        eps: float = 1e-4,
        max_iter: int = 100,
        damping: float = 1e-3,
        max_step: float = 0.2,
    ) -> IKResult:
        """Damped-least-squares IK of one group's leaf frame.

        Each iteration: error e = [p* - p; log(R* R^T)] (world frame, m and rad); stop when
        |e| < eps; else dq = J^T (J J^T + damping^2 I)^-1 e over the unlocked joints,
        scaled down so that max |dq| <= max_step, then clipped to the joint limits.

        Args:
            move_group_id: the group whose leaf frame is placed (an arm: its tool frame).
            pose: target pose, 4x4 (or 7 values); world frame unless ``rel_to_base``.
            unlocked_move_group_ids: groups whose joints may move (default the group).
            q0: initial joints per group id (default the reference state).
            base_pose: world pose of the primary base for a world ``pose``.
            rel_to_base: ``pose`` is in the group's robot frame.
            eps: convergence threshold on |e|; max_iter: most update steps.
        """
        check_ik_options(eps, max_iter, damping, max_step)
        view = self.robot_view
        group = view.get_move_group(move_group_id)
        unlocked = (
            [move_group_id] if unlocked_move_group_ids is None else list(unlocked_move_group_ids)
        )
        posadr, limits = self.unlocked_indices(unlocked)
        self.load(q0)
        target = self.world_target(group, pose, base_pose, rel_to_base)
        data, model = self.data, self.model
        q = data.qpos[posadr]
        residual, it = np.inf, 0
        for it in range(int(max_iter) + 1):
            if it:
                data.qpos[posadr] = q
                mujoco.mj_kinematics(model, data)
                mujoco.mj_comPos(model, data)
            err = pose_error(target, group.leaf_frame_to_world)
            residual = float(np.linalg.norm(err))
            if residual < eps or it == max_iter:
                break
            dq = damped_least_squares(view.get_jacobian(move_group_id, unlocked), err, damping)
            dq /= max(1.0, float(np.abs(dq).max()) / max_step)
            q = clip(q + dq, limits[:, 0], limits[:, 1])
        return IKResult(view.get_qpos_dict(), residual, it, residual < eps)
