"""4x4 transforms: conversions, inverse, rotation log against MuJoCo, pose error, checks."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.frames import (
    as_transform,
    check_transforms,
    invert,
    matrix_to_quat,
    pose7_to_transform,
    pose_error,
    relative,
    rotation_log,
    transform_to_pose7,
)
from trossen_arm_mujoco.robot.kinematics import orientation_error


def random_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quat_mat(q: np.ndarray) -> np.ndarray:
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, q)
    return mat.reshape(3, 3)


def test_pose7_roundtrip_and_inverse():
    rng = np.random.default_rng(0)
    for q in random_quats(rng, 20):
        pose = np.concatenate([rng.normal(size=3), q])
        tf = pose7_to_transform(pose)
        back = transform_to_pose7(tf)
        np.testing.assert_allclose(back[:3], pose[:3], atol=1e-12)
        assert min(np.abs(back[3:] - q).max(), np.abs(back[3:] + q).max()) < 1e-12
        assert back[3] >= 0
        np.testing.assert_allclose(invert(tf) @ tf, np.eye(4), atol=1e-12)
    tfs = np.stack([pose7_to_transform(np.r_[rng.normal(size=3), q]) for q in random_quats(rng, 5)])
    np.testing.assert_allclose(invert(tfs) @ tfs, np.broadcast_to(np.eye(4), (5, 4, 4)), atol=1e-12)
    np.testing.assert_allclose(relative(tfs[0], tfs[1]), np.linalg.inv(tfs[1]) @ tfs[0], atol=1e-12)


def test_matrix_to_quat_matches_mujoco_everywhere():
    rng = np.random.default_rng(1)
    quats = random_quats(rng, 200)
    # half turns about many axes: the Shepperd branches other than w
    axes = rng.normal(size=(20, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    quats = np.vstack([quats, np.c_[np.zeros(20), axes], np.eye(4)])
    mats = np.stack([quat_mat(q) for q in quats])
    got = matrix_to_quat(mats)
    for q, g in zip(quats, got):
        assert min(np.abs(g - q).max(), np.abs(g + q).max()) < 1e-12, (q, g)
    assert np.all(got[:, 0] >= 0)


def test_rotation_log_matches_mujoco_orientation_error():
    rng = np.random.default_rng(2)
    identity = np.array([1.0, 0, 0, 0])
    quats = random_quats(rng, 200)
    near_pi = np.c_[np.full(10, 1e-4), rng.normal(size=(10, 3))]  # 179.99 degrees
    tiny = np.c_[np.ones(5), rng.normal(size=(5, 3)) * 1e-9]
    for q in np.vstack([quats, near_pi, tiny, identity]):
        q = q / np.linalg.norm(q)
        expected = orientation_error(q, identity)  # MuJoCo's quat2Vel
        np.testing.assert_allclose(rotation_log(quat_mat(q)), expected, atol=1e-9)
    # exactly a half turn: the angle is pi about the right axis (either sign)
    axis = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    vec = rotation_log(quat_mat(np.r_[0.0, axis]))
    assert np.linalg.norm(vec) == pytest.approx(np.pi)
    assert abs(abs(vec @ axis) - np.pi) < 1e-9


def test_pose_error_is_position_and_world_rotation_vector():
    rng = np.random.default_rng(3)
    a, b = random_quats(rng, 2)
    ta = pose7_to_transform(np.r_[0.1, 0.2, 0.3, a])
    tb = pose7_to_transform(np.r_[-0.1, 0.0, 0.5, b])
    err = pose_error(ta, tb)
    np.testing.assert_allclose(err[:3], [0.2, 0.2, -0.2], atol=1e-12)
    np.testing.assert_allclose(err[3:], orientation_error(a, b), atol=1e-10)
    np.testing.assert_allclose(pose_error(np.stack([ta, tb]), np.stack([tb, tb]))[1], 0, atol=1e-12)


@pytest.mark.parametrize(
    ("pose", "match"),
    [
        (np.zeros((3, 3)), r"4x4 transform or 7 values .*got shape \(3, 3\)"),
        ([0, 0, 0, 0, 0, 0, 0], "quaternion .* zero length"),
        ([0, 0, np.nan, 1, 0, 0, 0], "NaN or inf"),
        (np.diag([1.0, 1.0, 2.0, 1.0]), "not a rotation matrix"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "not a rotation matrix"),
        (np.r_[np.eye(4)[:3], [[0, 0, 1, 1]]], r"last row .* \[0, 0, 0, 1\]"),
        ("pose", "4x4 transform or 7 values"),
    ],
)
def test_bad_poses_fail_in_one_line(pose, match):
    with pytest.raises(UserError, match=match) as err:
        as_transform("world pose", pose)
    assert "\n" not in str(err.value) and str(err.value).startswith("world pose")


def test_as_transform_accepts_both_forms():
    tf = as_transform("p", [0.1, 0.2, 0.3, 2.0, 0, 0, 0])  # quaternion normalised
    np.testing.assert_allclose(tf, np.r_[np.c_[np.eye(3), [0.1, 0.2, 0.3]], [[0, 0, 0, 1]]])
    assert as_transform("p", tf) is not tf
    check_transforms("p", np.stack([tf, tf]))
