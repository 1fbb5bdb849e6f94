"""ParallelKinematics: batched FK and damped-least-squares IK over N configurations at once.

The same algorithm as ``RobotKinematics.solve_ik`` (same error, step, scaling, clipping and
stopping rule per configuration), run on all N configurations together: the kinematics of
each leaf frame comes from a numpy ``KinematicChain`` evaluated on (N, ...) arrays, the
N small (6 x 6) damped least-squares systems are solved in one ``np.linalg.solve`` call, and
configurations leave the batch as they converge. Nothing here touches the caller's
``MjData``.

Frames and arguments follow ``RobotKinematics``: poses are 4x4 (or 7 values); world poses
unless ``rel_to_base``; ``base_poses`` place the robot's primary base per configuration.
Joints outside a group's chain (e.g. above its robot frame) come from the reference state.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.chain import KinematicChain
from trossen_arm_mujoco.robot.frames import as_transform, check_transforms, invert, pose_error_rp
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.robot_kinematics import RobotKinematics, check_ik_options

__all__ = ["BatchIKResult", "ParallelKinematics"]


@dataclass(frozen=True)
class BatchIKResult:
    """What a batched IK solve found, per configuration.

    q: (N, n) joint positions of the unlocked joints (rad / m), in the order of
        ``ParallelKinematics.unlocked_move_group_ids``.
    residual: (N,) norm of the final pose error [position (m); rotation vector (rad)].
    iterations: (N,) update steps taken.
    converged: (N,) ``residual < eps``.
    """

    q: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray


class ParallelKinematics:
    """Batched kinematics of a robot; IK of one move group's leaf frame.

    Args:
        kinematics: the robot's single-configuration solver (its model, config, private
            view and reference state are shared).
        move_group_id: the group IK places (an arm: its tool frame).
        unlocked_move_group_ids: groups whose joints IK may move (default the group).
    """

    def __init__(
        self,
        kinematics: RobotKinematics,
        move_group_id: str,
        unlocked_move_group_ids: Sequence[str] | None = None,
    ):
        self.kinematics = kinematics
        view = kinematics.robot_view
        self.move_group_id = move_group_id
        self.group = view.get_move_group(move_group_id)
        self.unlocked_move_group_ids = (
            [move_group_id] if unlocked_move_group_ids is None else list(unlocked_move_group_ids)
        )
        self._posadr, limits = kinematics.unlocked_indices(self.unlocked_move_group_ids)
        self._low, self._high = limits[:, 0].copy(), limits[:, 1].copy()
        columns = {int(adr): i for i, adr in enumerate(self._posadr)}
        self._chains: dict[str, KinematicChain | UserError] = {}
        for name, group in view.move_groups.items():
            try:
                cols = columns if name == move_group_id else None
                self._chains[name] = KinematicChain(
                    kinematics.model,
                    group.leaf_frame_type,
                    group.leaf_frame_id,
                    _robot_body(group),
                    cols,
                    len(self._posadr),
                )
            except UserError as exc:
                if name == move_group_id:
                    raise UserError(f"parallel kinematics of '{name}': {exc}") from None
                self._chains[name] = exc

    @property
    def n_unlocked(self) -> int:
        """Number of joints IK moves."""
        return len(self._posadr)

    # -- batches -------------------------------------------------------------------------
    def _reference_qpos(self, n: int) -> np.ndarray:
        return np.tile(np.asarray(self.kinematics.reference_state()[0], dtype=float), (n, 1))

    def _qpos_from_dicts(self, dicts: Sequence[Mapping[str, Sequence[float]] | None]) -> np.ndarray:
        qpos = self._reference_qpos(len(dicts))
        view = self.kinematics.robot_view
        for i, qd in enumerate(dicts):
            for name, q in (qd or {}).items():
                group = view.get_move_group(name)
                arr = np.asarray(q, dtype=float)
                if arr.shape != (group.pos_dim,) or not np.all(np.isfinite(arr)):
                    raise UserError(
                        f"configuration {i}, {name}: expected {group.pos_dim} finite joint "
                        f"values, got {np.round(arr, 4).tolist()}"
                    )
                qpos[i, group.qpos_idx] = arr
        return qpos

    def _robot_frames(self, group: MoveGroup, base_poses, n: int) -> np.ndarray:
        """(n, 4, 4) world poses of ``group``'s robot frame (reference state, bases placed)."""
        kin = self.kinematics
        kin.load()
        base = group.robot_base_group
        frame = base.pose if base is not None else group.root_frame_to_world
        if base_poses is None:
            return np.broadcast_to(frame, (n, 4, 4))
        placed = _transforms("base_poses", base_poses, n)
        return placed @ (invert(kin.robot_view.base.pose) @ frame)

    def _chain(self, name: str) -> KinematicChain:
        chain = self._chains[name]
        if isinstance(chain, UserError):
            raise UserError(f"parallel kinematics of '{name}': {chain}")
        return chain

    # -- forward kinematics --------------------------------------------------------------
    def leaf_poses(
        self,
        q: np.ndarray | None = None,
        base_poses=None,
        rel_to_base: bool = False,
        n: int | None = None,
    ) -> np.ndarray:
        """Leaf-frame poses of the IK group for a batch of its unlocked joints.

        Args:
            q: (N, n_unlocked) joints (rad / m); None: the reference state (``n`` copies,
                default 1).
            base_poses: (N, 4, 4) or (4, 4) world poses of the primary base.
            rel_to_base: poses in the group's robot frame.

        Returns:
            (N, 4, 4) poses.
        """
        if q is None:
            qpos = self._reference_qpos(1 if n is None else int(n))
        else:
            q = _batch("q", q, self.n_unlocked)
            qpos = self._reference_qpos(len(q))
            qpos[:, self._posadr] = q
        return self._poses(self.move_group_id, qpos, base_poses, rel_to_base)

    def _poses(self, name: str, qpos: np.ndarray, base_poses, rel_to_base: bool) -> np.ndarray:
        rot, pos, _ = self._chain(name).forward(qpos)
        rel = _stack(rot, pos)
        if rel_to_base:
            return rel
        group = self.kinematics.robot_view.get_move_group(name)
        return self._robot_frames(group, base_poses, len(qpos)) @ rel

    def fk(
        self,
        qpos_dicts: Sequence[Mapping[str, Sequence[float]]] | Mapping[str, Sequence[float]],
        base_poses=None,
        rel_to_base: bool = False,
    ) -> list[dict[str, np.ndarray]] | dict[str, np.ndarray]:
        """Leaf-frame pose (4x4) of every move group; see ``RobotKinematics.fk``.

        Args:
            qpos_dicts: move group id -> joint positions (rad / m), or a list of such dicts
                (one per configuration).
            base_poses: the robot base's world pose (4x4) per configuration, or one for all;
                None: the loaded state's.
            rel_to_base: poses relative to the robot frame instead of the world.

        Returns:
            Move group id -> 4x4 pose; a list of those for a list of dicts.
        """
        single = isinstance(qpos_dicts, Mapping)
        dicts = [qpos_dicts] if single else list(qpos_dicts)
        qpos = self._qpos_from_dicts(dicts)
        poses = {
            name: self._poses(name, qpos, base_poses, rel_to_base)
            for name in self.kinematics.robot_view.move_groups
        }
        out = [{name: p[i] for name, p in poses.items()} for i in range(len(dicts))]
        return out[0] if single else out

    # -- inverse kinematics --------------------------------------------------------------
    def warmup_ik(self, batch_size: int) -> None:
        """Run one IK step on ``batch_size`` configurations (allocations, caches) up front."""
        targets = self.leaf_poses(n=batch_size).copy()
        targets[:, :3, 3] += 0.01  # 1 cm off, so that the step is taken
        self.solve(targets, None, max_iter=1)

    def ik(
        self,
        poses: np.ndarray,
        q0_dicts: Sequence[Mapping[str, Sequence[float]]] | Mapping | None = None,
        **options: Any,
    ) -> list[dict[str, np.ndarray] | None] | dict[str, np.ndarray] | None:
        """Joint positions placing the group's leaf frame at each pose.

        Args:
            poses: (N, 4, 4) targets, or one (4, 4).
            q0_dicts: initial joints, one dict per target, or one dict for all (default the
                reference state).
            options: ``base_poses``, ``rel_to_base``, ``eps``, ``max_iter``, ``damping``,
                ``max_step``, as ``RobotKinematics.solve_ik`` takes them (see ``_solve``).

        Returns:
            One qpos dict (every group with joints) per target, None where the solve did not
            converge; a single dict / None for a single (4, 4) pose.
        """
        arr = np.asarray(poses, dtype=float)
        single = arr.ndim == 2
        n = 1 if single else len(arr)
        if q0_dicts is None or isinstance(q0_dicts, Mapping):
            dicts = [q0_dicts] * n
        else:
            dicts = list(q0_dicts)
            if len(dicts) != n:
                raise UserError(f"ik: {len(dicts)} initial configurations for {n} poses")
        qpos = self._qpos_from_dicts(dicts)
        result = self._solve(arr, qpos, **options)
        qpos[:, self._posadr] = result.q
        view = self.kinematics.robot_view
        out = [
            {name: qpos[i, g.qpos_idx] for name, g in view.move_groups.items() if g.n_joints}
            if result.converged[i]
            else None
            for i in range(n)
        ]
        return out[0] if single else out

    def solve(
        self, poses: np.ndarray, q0: np.ndarray | None = None, **options: Any
    ) -> BatchIKResult:
        """Batched IK on arrays. Per configuration the result equals
        ``RobotKinematics.solve_ik`` with the same arguments.

        Args:
            poses: (N, 4, 4) target leaf-frame poses (or one (4, 4) for all ``q0``).
            q0: (N, n_unlocked) initial joints (rad / m); None: the reference state.
            **options: as for ``ik`` (``eps``, ``max_iter``, ``damping``, ``max_step``, ...).
        """
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 3:
            n = len(arr)
        else:
            n = len(q0) if q0 is not None and np.ndim(q0) == 2 else 1
        qpos = self._reference_qpos(n)
        if q0 is not None:
            qpos[:, self._posadr] = _batch("q0", q0, self.n_unlocked, n)
        return self._solve(arr, qpos, **options)

    def _solve(
        self,
        poses,
        qpos: np.ndarray,
        base_poses=None,
        rel_to_base: bool = False,
        eps: float = 1e-4,
        max_iter: int = 100,
        damping: float = 1e-3,
        max_step: float = 0.2,
    ) -> BatchIKResult:
        """IK from full initial qpos (N, nq); the targets are world poses unless
        ``rel_to_base``, where they are in the group's robot frame (``base_poses``: (N, 4, 4)
        or one robot base pose; the solver settings as in ``RobotKinematics.solve_ik``)."""
        check_ik_options(eps, max_iter, damping, max_step)
        n = len(qpos)
        targets = _transforms("poses", poses, n)
        if not rel_to_base:  # into the group's robot frame, where the chain works
            targets = invert(self._robot_frames(self.group, base_poses, n)) @ targets
        chain, posadr, low, high = (
            self._chain(self.move_group_id),
            self._posadr,
            self._low,
            self._high,
        )
        q = qpos[:, posadr].copy()  # final joints, written back as configurations finish
        residual = np.full(n, np.inf)
        iterations = np.zeros(n, dtype=int)
        reg = damping**2 * np.eye(6)
        # the configurations still iterating: their indices, targets, full qpos, joints
        active, t_rot, t_pos = np.arange(n), targets[:, :3, :3], targets[:, :3, 3]
        sub, q_sub = qpos.copy(), q.copy()
        for it in range(int(max_iter) + 1):
            sub[:, posadr] = q_sub
            rot, pos, jac = chain.forward(sub, jacobian=it < max_iter)
            err = pose_error_rp(t_rot, t_pos, rot, pos)
            res = np.sqrt(np.einsum("ij,ij->i", err, err))
            residual[active] = res
            iterations[active] = it
            going = res >= eps
            if it == max_iter or not going.any():
                break
            if not going.all():  # finished ones leave the batch
                q[active[~going]] = q_sub[~going]
                active, t_rot, t_pos = active[going], t_rot[going], t_pos[going]
                sub, q_sub, jac, err = sub[going], q_sub[going], jac[going], err[going]
            jac_t = np.swapaxes(jac, 1, 2)
            dq = (jac_t @ np.linalg.solve(jac @ jac_t + reg, err[:, :, None]))[:, :, 0]
            dq /= np.maximum(1.0, np.abs(dq).max(axis=1) / max_step)[:, None]
            q_sub = clip(q_sub + dq, low, high)
        q[active] = q_sub
        return BatchIKResult(q, residual, iterations, residual < eps)


def _robot_body(group: MoveGroup) -> int:
    """The body whose frame is ``group``'s robot frame (its base's, else its root)."""
    base = group.robot_base_group
    return base.body_id if base is not None else group.root_body_id


def _stack(rot: np.ndarray, pos: np.ndarray) -> np.ndarray:
    out = np.zeros((len(rot), 4, 4))
    out[:, :3, :3] = rot
    out[:, :3, 3] = pos
    out[:, 3, 3] = 1.0
    return out


def _transforms(name: str, poses, n: int) -> np.ndarray:
    """(n, 4, 4) checked transforms from (n, 4, 4), one (4, 4) or one 7-value pose."""
    arr = np.asarray(poses, dtype=float)
    if arr.shape in ((4, 4), (7,)):
        return np.broadcast_to(as_transform(name, arr), (n, 4, 4))
    if arr.shape != (n, 4, 4):
        raise UserError(f"{name}: expected ({n}, 4, 4) transforms or one (4, 4), got {arr.shape}")
    check_transforms(name, arr)
    return arr


def _batch(name: str, values, width: int, n: int | None = None) -> np.ndarray:
    """(N, width) finite float array (one (width,) row is repeated to ``n``)."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim == 1 and n is not None:
        arr = np.broadcast_to(arr, (n, arr.size))
    if arr.ndim != 2 or arr.shape[1] != width or (n is not None and len(arr) != n):
        want = f"({n if n is not None else 'N'}, {width})"
        raise UserError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise UserError(f"{name}: contains NaN or inf")
    return arr
