"""Rigid transforms as 4x4 homogeneous matrices, batched where it matters.

A transform ``T_a_to_b`` (a 4x4 array) maps points of frame ``a`` into frame ``b``: its
rotation block ``T[:3, :3]`` holds ``a``'s axes in ``b``, its last column ``T[:3, 3]`` is
``a``'s origin in ``b`` (m). ``leaf_frame_to_world`` is the pose of the leaf frame in the
world. Every function takes leading batch dimensions (``(..., 4, 4)``) unless it says
otherwise. Quaternions are [w, x, y, z]; 7-value poses are [x, y, z, qw, qx, qy, qz].

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "as_transform",
    "check_transforms",
    "frame_jacobian",
    "frame_transform",
    "invert",
    "matrix_to_quat",
    "pose7_to_transform",
    "pose_error",
    "pose_error_rp",
    "relative",
    "rotation_log",
    "transform",
    "transform_to_pose7",
]


def transform(pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """4x4 transform from a position (3,) m and a rotation matrix (3, 3) (or 9 values)."""
    out = np.eye(4)
    out[:3, :3] = np.reshape(rot, (3, 3))
    out[:3, 3] = pos
    return out


def pose7_to_transform(pose: np.ndarray) -> np.ndarray:
    """[x, y, z, qw, qx, qy, qz] (m) -> 4x4 transform; the quaternion is normalised."""
    pose = np.asarray(pose, dtype=float)
    mat = np.empty(9)
    quat = pose[3:] / np.linalg.norm(pose[3:])
    mujoco.mju_quat2Mat(mat, quat)
    return transform(pose[:3], mat)


def transform_to_pose7(tf: np.ndarray) -> np.ndarray:
    """4x4 transform -> [x, y, z, qw, qx, qy, qz] (m), with qw >= 0."""
    out = np.empty(7)
    out[:3] = tf[:3, 3]
    mujoco.mju_mat2Quat(out[3:], np.ascontiguousarray(tf[:3, :3]).reshape(9))
    if out[3] < 0:
        out[3:] *= -1
    return out


def invert(tf: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms, (..., 4, 4): [R^T, -R^T t]."""
    tf = np.asarray(tf, dtype=float)
    out = np.zeros_like(tf)
    rot_t = np.swapaxes(tf[..., :3, :3], -1, -2)
    out[..., :3, :3] = rot_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rot_t, tf[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def relative(tf_a: np.ndarray, tf_b: np.ndarray) -> np.ndarray:
    """Pose of frame a in frame b, given both in a common frame: ``inv(tf_b) @ tf_a``."""
    return invert(tf_b) @ tf_a


def as_transform(name: str, pose) -> np.ndarray:
    """A user's pose as a checked 4x4 transform (a copy), else a one-line UserError.

    Args:
        name: what the pose is, for the message (e.g. "world pose").
        pose: 4x4 homogeneous transform, or 7 values [x, y, z, qw, qx, qy, qz] (m).
    """
    try:
        arr = np.array(pose, dtype=float)
    except (TypeError, ValueError):
        raise UserError(f"{name}: expected a 4x4 transform or 7 values, got {pose!r}") from None
    if arr.shape == (7,):
        if not np.all(np.isfinite(arr)):
            raise UserError(f"{name}: contains NaN or inf: {np.round(arr, 4).tolist()}")
        if np.linalg.norm(arr[3:]) < 1e-9:
            raise UserError(f"{name}: the quaternion [qw, qx, qy, qz] has zero length")
        return pose7_to_transform(arr)
    if arr.shape != (4, 4):
        raise UserError(
            f"{name}: expected a 4x4 transform or 7 values [x, y, z, qw, qx, qy, qz], "
            f"got shape {arr.shape}"
        )
    check_transforms(name, arr)
    return arr


def check_transforms(name: str, tf: np.ndarray, tol: float = 1e-6) -> None:
    """UserError unless ``tf`` holds finite rigid transforms.

    Args:
        name: what the transforms are, named in the error.
        tf: (..., 4, 4) transforms: an orthonormal, right-handed rotation block and a last
            row [0, 0, 0, 1].
        tol: tolerance of the rotation block's orthonormality.
    """
    if tf.shape[-2:] != (4, 4):
        raise UserError(f"{name}: expected 4x4 transforms, got shape {tf.shape}")
    if not np.all(np.isfinite(tf)):
        raise UserError(f"{name}: contains NaN or inf")
    rot = tf[..., :3, :3]
    gram = rot @ np.swapaxes(rot, -1, -2)
    if np.abs(gram - np.eye(3)).max(initial=0.0) > tol or np.any(np.linalg.det(rot) < 0):
        raise UserError(f"{name}: the 3x3 rotation block is not a rotation matrix")
    if np.abs(tf[..., 3, :] - [0.0, 0.0, 0.0, 1.0]).max(initial=0.0) > tol:
        raise UserError(f"{name}: the last row of a 4x4 transform must be [0, 0, 0, 1]")


def matrix_to_quat(rot: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) [w, x, y, z], w >= 0.

    Shepperd's method: the largest of |w|, |x|, |y|, |z| is taken from the diagonal, the
    others from the off-diagonal sums, so it stays accurate near 180 degrees."""
    m = np.asarray(rot, dtype=float)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    cand = np.stack(
        [1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22],
        axis=-1,
    )  # 4 w^2, 4 x^2, 4 y^2, 4 z^2
    k = cand.argmax(axis=-1)
    s = 2.0 * np.sqrt(np.take_along_axis(cand, k[..., None], axis=-1)[..., 0])  # 4 |q_k|
    a = m[..., 2, 1] - m[..., 1, 2]  # 4 w x
    b = m[..., 0, 2] - m[..., 2, 0]  # 4 w y
    c = m[..., 1, 0] - m[..., 0, 1]  # 4 w z
    d = m[..., 0, 1] + m[..., 1, 0]  # 4 x y
    e = m[..., 0, 2] + m[..., 2, 0]  # 4 x z
    f = m[..., 1, 2] + m[..., 2, 1]  # 4 y z
    quarter = s / 4
    w = np.choose(k, [quarter, a / s, b / s, c / s])
    x = np.choose(k, [a / s, quarter, d / s, e / s])
    y = np.choose(k, [b / s, d / s, quarter, f / s])
    z = np.choose(k, [c / s, e / s, f / s, quarter])
    q = np.stack([w, x, y, z], axis=-1)
    q *= np.where(w < 0, -1.0, 1.0)[..., None]
    return q


def rotation_log(rot: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) (axis * angle, rad, angle in [0, pi]) of rotation matrices.

    From the skew part (sin(angle) * axis) and the trace (cos(angle)); within 8 degrees of
    a half turn, where the skew part vanishes, from the quaternion (``matrix_to_quat``)."""
    r = np.asarray(rot, dtype=float)
    vee = 0.5 * np.stack(
        [r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]],
        axis=-1,
    )
    cos = np.clip(0.5 * (r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2] - 1.0), -1.0, 1.0)
    sin = np.sqrt(np.einsum("...i,...i->...", vee, vee))
    angle = np.arctan2(sin, cos)
    scale = np.where(sin > 1e-12, angle / np.where(sin > 1e-12, sin, 1.0), 1.0)
    out = vee * scale[..., None]
    near_pi = cos < -0.99
    if np.any(near_pi):
        q = matrix_to_quat(r[near_pi])
        half_sin = np.linalg.norm(q[..., 1:], axis=-1)
        out[near_pi] = q[..., 1:] * (2.0 * np.arctan2(half_sin, q[..., 0]) / half_sin)[..., None]
    return out


def pose_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Twist that moves ``current`` onto ``target`` (both (..., 4, 4) in one frame F).

    Returns:
        (..., 6): [target origin - current origin (m); rotation vector of
        R_target R_current^T (rad)], both expressed in F.
    """
    return pose_error_rp(
        target[..., :3, :3], target[..., :3, 3], current[..., :3, :3], current[..., :3, 3]
    )


def pose_error_rp(
    target_rot: np.ndarray, target_pos: np.ndarray, rot: np.ndarray, pos: np.ndarray
) -> np.ndarray:
    """``pose_error`` from rotations and positions.

    Args:
        target_rot: (..., 3, 3) target rotations.
        target_pos: (..., 3) target positions (m).
        rot: (..., 3, 3) current rotations.
        pos: (..., 3) current positions (m).

    Returns:
        (..., 6): as :func:`pose_error`.
    """
    r_err = target_rot @ np.swapaxes(rot, -1, -2)
    return np.concatenate([target_pos - pos, rotation_log(r_err)], axis=-1)


def frame_transform(data: mujoco.MjData, frame_type: str, frame_id: int) -> np.ndarray:
    """World pose (4x4) of a site or body of ``data`` (after ``mj_kinematics``).

    Args:
        data: the state.
        frame_type: ``"site"`` or ``"body"``.
        frame_id: the site's or body's id.
    """
    if frame_type == "site":
        return transform(data.site_xpos[frame_id], data.site_xmat[frame_id])
    return transform(data.xpos[frame_id], data.xmat[frame_id])


def frame_jacobian(
    model: mujoco.MjModel, data: mujoco.MjData, frame_type: str, frame_id: int
) -> np.ndarray:
    """(6, nv) Jacobian of a site (``mj_jacSite``) or body origin (``mj_jacBody``): rows
    [linear (m/unit); angular (rad/unit)], world frame. Needs ``mj_kinematics`` and
    ``mj_comPos`` (or ``mj_forward``) for the current qpos.

    Args:
        model: compiled model.
        data: the state.
        frame_type: ``"site"`` or ``"body"``.
        frame_id: the site's or body's id.
    """
    jac = np.zeros((6, model.nv))
    jac_fn = mujoco.mj_jacSite if frame_type == "site" else mujoco.mj_jacBody
    jac_fn(model, data, jac[:3], jac[3:], frame_id)
    return jac
