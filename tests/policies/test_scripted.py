"""Waypoint trajectories: building, checking, interpolating (slerp) and noise."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.policies.scripted import (
    add_position_noise,
    check_waypoints,
    interpolate,
    waypoint,
)
from trossen_arm_mujoco.quaternion import Quaternion

IDENTITY = [1.0, 0.0, 0.0, 0.0]
YAW_90 = Quaternion(axis=[0, 0, 1], degrees=90).elements


def _same_rotation(q, r) -> bool:
    """q and -q are the same rotation."""
    q, r = np.asarray(q), np.asarray(r)
    return bool(np.allclose(q, r, atol=1e-9) or np.allclose(q, -r, atol=1e-9))


@pytest.fixture
def path():
    return [
        waypoint(0, [0.0, 0.0, 0.0], IDENTITY, 0.044),
        waypoint(10, [1.0, 2.0, -1.0], YAW_90, 0.0),
        waypoint(30, [1.0, 2.0, 1.0], YAW_90, 0.02),
    ]


# ----------------------------------------------------------------------------- waypoint
def test_waypoint_copies_and_converts():
    xyz, quat = [1, 2, 3], np.array([1, 0, 0, 0])
    w = waypoint(5, xyz, quat, 0)
    assert set(w) == {"t", "xyz", "quat", "gripper"}
    assert isinstance(w["t"], float) and isinstance(w["gripper"], float)
    assert w["xyz"].dtype == float and w["quat"].dtype == float
    quat[0] = 9  # the waypoint owns its arrays
    assert w["quat"][0] == 1.0


# ----------------------------------------------------------------------------- checks
def test_valid_waypoints_pass(path):
    check_waypoints(path, "demo")


@pytest.mark.parametrize(
    ("times", "message"),
    [((1, 2), "start at 0"), ((0, 5, 5), "increase"), ((0, 5, 3), "increase")],
)
def test_times_must_start_at_zero_and_increase(times, message):
    ws = [waypoint(t, [0, 0, 0], IDENTITY, 0) for t in times]
    with pytest.raises(UserError, match=message) as exc:
        check_waypoints(ws, "left arm")
    assert str(exc.value).startswith("left arm: ")


def test_no_waypoints():
    with pytest.raises(UserError, match="right arm: no waypoints"):
        check_waypoints([], "right arm")


@pytest.mark.parametrize("field", ["xyz", "quat", "gripper"])
def test_non_finite_values_are_named(path, field):
    bad = dict(path[1])
    bad[field] = np.nan if field == "gripper" else np.r_[bad[field][:-1], np.inf]
    with pytest.raises(UserError, match=r"waypoint at t=10\.0 has NaN or inf"):
        check_waypoints([path[0], bad, path[2]], "arm")


# ----------------------------------------------------------------------------- interpolate
def test_values_at_waypoint_times(path):
    for w in path:
        out = interpolate(path, w["t"])
        assert out.shape == (8,)
        np.testing.assert_allclose(out[:3], w["xyz"])
        assert _same_rotation(out[3:7], w["quat"])
        assert out[7] == pytest.approx(w["gripper"])


def test_holds_the_end_values_before_and_after(path):
    before, after = interpolate(path, -5), interpolate(path, 1e6)
    np.testing.assert_allclose(before, [0, 0, 0, *IDENTITY, 0.044])
    np.testing.assert_allclose(after, [1, 2, 1, *YAW_90, 0.02])
    np.testing.assert_array_equal(interpolate(path, 31), after)


def test_linear_position_and_gripper(path):
    out = interpolate(path, 2.5)  # a quarter of the first segment
    np.testing.assert_allclose(out[:3], [0.25, 0.5, -0.25])
    assert out[7] == pytest.approx(0.044 * 0.75)
    out = interpolate(path, 20)  # halfway through the second segment
    np.testing.assert_allclose(out[:3], [1.0, 2.0, 0.0])
    assert out[7] == pytest.approx(0.01)


def test_slerp_halfway_is_half_the_rotation(path):
    out = interpolate(path, 5)
    assert _same_rotation(out[3:7], Quaternion(axis=[0, 0, 1], degrees=45).elements)
    assert np.linalg.norm(out[3:7]) == pytest.approx(1.0)
    # constant angular speed: a quarter of the time, a quarter of the angle
    angle = 2 * np.degrees(np.arccos(abs(interpolate(path, 2.5)[3])))
    assert angle == pytest.approx(22.5)


def test_slerp_takes_the_short_way_and_normalises():
    q1 = -Quaternion(axis=[1, 0, 0], degrees=60).elements  # same rotation, far hemisphere
    ws = [waypoint(0, [0, 0, 0], [2.0, 0, 0, 0], 0), waypoint(2, [0, 0, 0], q1, 0)]
    mid = interpolate(ws, 1)[3:7]
    assert _same_rotation(mid, Quaternion(axis=[1, 0, 0], degrees=30).elements)
    np.testing.assert_allclose(interpolate(ws, 0)[3:7], IDENTITY)  # normalised


# ----------------------------------------------------------------------------- noise
def test_noise_is_deterministic_per_seed_and_bounded(path):
    a = add_position_noise(path, np.random.default_rng(7), 0.01)
    b = add_position_noise(path, np.random.default_rng(7), 0.01)
    c = add_position_noise(path, np.random.default_rng(8), 0.01)
    for wa, wb in zip(a, b, strict=True):
        np.testing.assert_array_equal(wa["xyz"], wb["xyz"])
    assert any(not np.array_equal(wa["xyz"], wc["xyz"]) for wa, wc in zip(a, c, strict=True))
    for w, orig in zip(a[1:], path[1:], strict=True):
        delta = w["xyz"] - orig["xyz"]
        assert np.all(np.abs(delta) <= 0.01) and np.any(delta != 0)
        np.testing.assert_array_equal(w["quat"], orig["quat"])
        assert (w["t"], w["gripper"]) == (orig["t"], orig["gripper"])


def test_noise_skips_the_first_waypoint_unless_asked(path):
    kept = add_position_noise(path, np.random.default_rng(0), 0.05)
    np.testing.assert_array_equal(kept[0]["xyz"], path[0]["xyz"])
    moved = add_position_noise(path, np.random.default_rng(0), 0.05, skip_first=False)
    assert not np.array_equal(moved[0]["xyz"], path[0]["xyz"])


def test_noise_leaves_the_input_untouched(path):
    before = [w["xyz"].copy() for w in path]
    out = add_position_noise(path, np.random.default_rng(1), 0.05)
    assert all(o is not w for o, w in zip(out, path, strict=True))
    for w, xyz in zip(path, before, strict=True):
        np.testing.assert_array_equal(w["xyz"], xyz)


def test_noise_draws_three_values_per_noisy_waypoint(path):
    """The generator advances by exactly the draws made, so callers sharing it stay
    reproducible."""
    rng = np.random.default_rng(3)
    add_position_noise(path, rng, 0.01)
    expected = np.random.default_rng(3)
    expected.uniform(-0.01, 0.01, size=3 * (len(path) - 1))
    assert rng.random() == expected.random()
