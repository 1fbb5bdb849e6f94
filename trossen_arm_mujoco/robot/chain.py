"""KinematicChain: batched forward kinematics and Jacobian of one frame, in numpy.

For N joint configurations at once, the pose of a frame (a site or a body) relative to a
reference body above it (the robot's base), and its Jacobian w.r.t. chosen joints. It
repeats what ``mj_kinematics`` does along the chain of bodies in between (each body's
fixed offset, then its joints: hinge rotations about their anchors and slide translations,
both measured from ``qpos0``), with (N, 3, 3) rotation matrices instead of one body at a
time, so the cost per configuration shrinks with N. Hinge and slide joints only.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = ["KinematicChain"]

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)


def _quat_to_mat(quat: np.ndarray) -> np.ndarray:
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class KinematicChain:
    """Pose of a frame in a reference body's frame, for a batch of configurations.

    Args:
        model: compiled model.
        frame_type, frame_id: the frame ("site" or "body", and its id).
        ref_body: id of a body above the frame (0: the world); poses are in its frame.
        columns: qpos address -> Jacobian column, for the joints to differentiate by.
        n_columns: number of Jacobian columns (joints not on the chain give zero columns).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        frame_type: str,
        frame_id: int,
        ref_body: int,
        columns: Mapping[int, int] | None = None,
        n_columns: int = 0,
    ):
        columns = dict(columns or {})
        self.n_columns = n_columns
        leaf = int(model.site_bodyid[frame_id]) if frame_type == "site" else int(frame_id)
        bodies = []
        body = leaf
        while body != ref_body:
            if body == 0:
                raise UserError(
                    f"frame {frame_type} '{_name(model, frame_type, frame_id)}' is not below "
                    f"body '{_name(model, 'body', ref_body)}'"
                )
            bodies.append(body)
            body = int(model.body_parentid[body])
        # The chain as steps, each a body's fixed offset (pos, rot) merged into the joint
        # that follows it: ("fixed", pos, rot), or a joint step ("hinge" / "slide", ...).
        self.steps: list[tuple] = []
        offset = (np.zeros(3), np.eye(3))  # fixed offset not yet taken by a step
        for body in reversed(bodies):
            if model.body_mocapid[body] >= 0:
                raise UserError(
                    f"body '{_name(model, 'body', body)}' is a mocap body inside a kinematic "
                    "chain; batched kinematics follows joints only"
                )
            offset = _compose(offset, (model.body_pos[body], _quat_to_mat(model.body_quat[body])))
            start = int(model.body_jntadr[body])
            for jnt in range(start, start + int(model.body_jntnum[body])):
                jtype = int(model.jnt_type[jnt])
                if jtype not in (_HINGE, _SLIDE):
                    raise UserError(
                        f"joint '{_name(model, 'joint', jnt)}' is not a hinge or slide; batched "
                        "kinematics follows hinge and slide joints only"
                    )
                adr = int(model.jnt_qposadr[jnt])
                self.steps.append(
                    _joint_step(jtype, offset, model.jnt_axis[jnt], model.jnt_pos[jnt])
                    + (float(model.qpos0[adr]), adr, columns.get(adr, -1))
                )
                offset = (np.zeros(3), np.eye(3))
        if frame_type == "site":
            offset = _compose(
                offset, (model.site_pos[frame_id], _quat_to_mat(model.site_quat[frame_id]))
            )
        self.steps.append(("fixed", offset[0], offset[1]))
        self.qpos_adr = sorted({s[-2] for s in self.steps if s[0] != "fixed"})

    def forward(
        self, qpos: np.ndarray, jacobian: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Frame poses for a batch of configurations.

        Args:
            qpos: (N, nq) full joint positions (only the chain's joints are read).
            jacobian: also return the Jacobian.

        Returns:
            rot (N, 3, 3), pos (N, 3) (m): the frame in the reference body's frame; and None
            or the Jacobian (N, 6, n_columns), rows [linear (m/unit); angular (rad/unit)] in
            the reference body's frame.
        """
        n = qpos.shape[0]
        rot = np.broadcast_to(np.eye(3), (n, 3, 3))
        pos = np.zeros((n, 3))
        joints: list[tuple[bool, int, np.ndarray, np.ndarray]] = []  # hinge?, col, axis, anchor
        for step in self.steps:
            kind = step[0]
            if kind == "fixed":
                pos = pos + _rotate(rot, step[1])
                rot = _times(rot, step[2])
                continue
            col = step[-1]
            value = qpos[:, step[-2]] - step[-3]
            if kind == "slide":  # (kind, offset pos, offset rot, axis in parent frame, ...)
                _, off_pos, off_rot, axis = step[:4]
                world_axis = _rotate(rot, axis)
                pos = pos + _rotate(rot, off_pos) + world_axis * value[:, None]
                rot = _times(rot, off_rot)
                if jacobian and col >= 0:
                    joints.append((False, col, world_axis, pos))
                continue
            # hinge: (kind, offset pos, F, F K, F K^2, F anchor, anchor, F axis, ...), F the
            # offset rotation, K the axis' cross-product matrix: rot F R(value) =
            # rot F + sin(value) rot F K + (1 - cos(value)) rot F K^2 (Rodrigues)
            _, off_pos, f, fk, fk2, f_anchor, anchor, f_axis = step[:8]
            pos = pos + _rotate(rot, off_pos)
            world_anchor = pos + _rotate(rot, f_anchor) if f_anchor is not None else pos
            world_axis = _rotate(rot, f_axis)
            s, c = np.sin(value)[:, None, None], np.cos(value)[:, None, None]
            rot = _times(rot, f) + s * _times(rot, fk) + (1.0 - c) * _times(rot, fk2)
            if f_anchor is not None:
                pos = world_anchor - _rotate(rot, anchor)
            if jacobian and col >= 0:
                joints.append((True, col, world_axis, world_anchor))
        rot = np.ascontiguousarray(rot)
        if not jacobian:
            return rot, pos, None
        jac = np.zeros((n, 6, self.n_columns))
        for hinge, col, world_axis, world_anchor in joints:
            if hinge:
                jac[:, :3, col] = _cross(world_axis, pos - world_anchor)
                jac[:, 3:, col] = world_axis
            else:
                jac[:, :3, col] = world_axis
        return rot, pos, jac


def _compose(a: tuple, b: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Offset a then b: (p_a + R_a p_b, R_a R_b)."""
    return np.asarray(a[0]) + a[1] @ np.asarray(b[0], dtype=float), a[1] @ b[1]


def _joint_step(jtype: int, offset: tuple, axis: np.ndarray, anchor: np.ndarray) -> tuple:
    """The constant part of a joint step that follows the fixed ``offset``."""
    pos, f = np.array(offset[0], dtype=float), np.array(offset[1], dtype=float)
    axis = np.array(axis, dtype=float)
    if jtype == _SLIDE:
        return ("slide", pos, f, f @ axis)
    k = _skew(axis)
    anchor = np.array(anchor, dtype=float)
    f_anchor = f @ anchor if anchor.any() else None
    return ("hinge", pos, f, f @ k, f @ k @ k, f_anchor, anchor, f @ axis)


def _rotate(rot: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """(N, 3, 3) @ (3,) -> (N, 3), as one matrix-vector product."""
    return (rot.reshape(-1, 3) @ vec).reshape(-1, 3)


def _times(rot: np.ndarray, mat: np.ndarray) -> np.ndarray:
    """(N, 3, 3) @ (3, 3) -> (N, 3, 3), as one matrix product (not N small ones)."""
    return (rot.reshape(-1, 3) @ mat).reshape(-1, 3, 3)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (N, 3) arrays (``np.cross`` costs more at these sizes)."""
    out = np.empty_like(b)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _name(model: mujoco.MjModel, kind: str, idx: int) -> str:
    obj = {"body": mujoco.mjtObj.mjOBJ_BODY, "site": mujoco.mjtObj.mjOBJ_SITE}.get(
        kind, mujoco.mjtObj.mjOBJ_JOINT
    )
    return mujoco.mj_id2name(model, obj, idx) or f"#{idx}"
