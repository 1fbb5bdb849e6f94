"""Quaternion against MuJoCo's own quaternion functions."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.quaternion import Quaternion


def random_unit_quats(n: int, seed: int = 0) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def same_rotation(a, b, tol=1e-12) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return min(np.abs(a - b).max(), np.abs(a + b).max()) < tol


def test_constructors():
    np.testing.assert_array_equal(Quaternion().elements, [1, 0, 0, 0])
    np.testing.assert_array_equal(Quaternion([0.5, 0.5, 0.5, 0.5]).elements, [0.5] * 4)
    q = Quaternion([1, 2, 3, 4])
    copy = Quaternion(q)
    copy.elements[0] = 9
    assert q.elements[0] == 1  # copies, does not alias
    with pytest.raises(ValueError):
        Quaternion([1, 2, 3])
    with pytest.raises(ValueError, match="non-zero"):
        Quaternion(axis=[0, 0, 0], degrees=10)


@pytest.mark.parametrize(
    ("axis", "angle"), [([0, 1, 0], -90.0), ([1, 0, 0], 45.0), ([1, 2, 3], 200.0), ([0, 0, 5], 0)]
)
def test_axis_angle_matches_mujoco(axis, angle):
    expected = np.zeros(4)
    unit = np.asarray(axis, float) / np.linalg.norm(axis)
    mujoco.mju_axisAngle2Quat(expected, unit, np.deg2rad(angle))
    np.testing.assert_allclose(Quaternion(axis=axis, degrees=angle).elements, expected, atol=1e-15)
    np.testing.assert_allclose(
        Quaternion(axis=axis, radians=np.deg2rad(angle)).elements, expected, atol=1e-15
    )


def test_composition_matches_mujoco():
    qs = random_unit_quats(20)
    for a, b in zip(qs[:10], qs[10:], strict=True):
        expected = np.zeros(4)
        mujoco.mju_mulQuat(expected, a, b)
        np.testing.assert_allclose((Quaternion(a) * Quaternion(b)).elements, expected, atol=1e-15)
        np.testing.assert_allclose((Quaternion(a) * b).elements, expected, atol=1e-15)


def test_composition_order_b_first_then_a():
    a = Quaternion(axis=[0, 0, 1], degrees=90)
    b = Quaternion(axis=[1, 0, 0], degrees=90)
    v = np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose((a * b).rotate(v), a.rotate(b.rotate(v)), atol=1e-12)
    np.testing.assert_allclose((a * b).rotate(v), [-0.0, 0.0, 1.0], atol=1e-12)


def test_rotate_matches_mujoco():
    v = np.array([0.3, -1.2, 2.0])
    for q in random_unit_quats(10, seed=1):
        expected = np.zeros(3)
        mujoco.mju_rotVecQuat(expected, v, q)
        np.testing.assert_allclose(Quaternion(q).rotate(v), expected, atol=1e-12)


def test_conjugate_inverse_normalised():
    q = Quaternion([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(q.conjugate.elements, [1, -2, -3, -4])
    np.testing.assert_allclose((q * q.inverse).elements, [1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(q.normalised.elements), 1.0)
    expected = np.zeros(4)
    mujoco.mju_negQuat(expected, q.normalised.elements)
    np.testing.assert_allclose(q.normalised.conjugate.elements, expected)


def test_slerp_endpoints_and_midpoint():
    a = Quaternion(axis=[0, 0, 1], degrees=10)
    b = Quaternion(axis=[0, 0, 1], degrees=110)
    np.testing.assert_allclose(Quaternion.slerp(a, b, 0.0).elements, a.elements, atol=1e-12)
    np.testing.assert_allclose(Quaternion.slerp(a, b, 1.0).elements, b.elements, atol=1e-12)
    mid = Quaternion.slerp(a, b, 0.5)
    expected = Quaternion(axis=[0, 0, 1], degrees=60)
    np.testing.assert_allclose(mid.elements, expected.elements, atol=1e-12)


def test_slerp_constant_angular_speed_matches_mujoco():
    """slerp(a, b, t) = a turned by t * (rotation a -> b), via mju_subQuat / mju_quatIntegrate."""
    qs = random_unit_quats(8, seed=2)
    for a, b in zip(qs[:4], qs[4:], strict=True):
        vel = np.zeros(3)
        mujoco.mju_subQuat(vel, b, a)  # a * exp(vel) = b (local frame of a)
        for t in (0.25, 0.5, 0.8):
            expected = a.copy()
            mujoco.mju_quatIntegrate(expected, vel, t)
            assert same_rotation(Quaternion.slerp(a, b, t).elements, expected, tol=1e-9)


def test_slerp_takes_the_shortest_path():
    a = Quaternion(axis=[1, 0, 0], degrees=0)
    b = Quaternion(-Quaternion(axis=[1, 0, 0], degrees=90).elements)  # same rotation, other sign
    mid = Quaternion.slerp(a, b, 0.5)
    assert same_rotation(mid.elements, Quaternion(axis=[1, 0, 0], degrees=45).elements)


def test_slerp_nearly_equal_quaternions():
    a = Quaternion(axis=[0, 1, 0], degrees=30)
    b = Quaternion(axis=[0, 1, 0], degrees=30.001)
    mid = Quaternion.slerp(a, b, 0.5)
    np.testing.assert_allclose(np.linalg.norm(mid.elements), 1.0)
    assert same_rotation(mid.elements, Quaternion(axis=[0, 1, 0], degrees=30.0005).elements, 1e-9)


def test_repr():
    assert repr(Quaternion()) == "Quaternion([1.0, 0.0, 0.0, 0.0])"
