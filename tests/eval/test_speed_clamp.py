"""``eval.speed_clamp``: goals shortened to a share of the real speed limits."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.eval.speed_clamp import KIT_SPEED_LIMITS, PEAK_TO_MEAN, SpeedClamp


def test_limits_are_the_kits_in_driver_order() -> None:
    assert KIT_SPEED_LIMITS.shape == (14,)
    assert KIT_SPEED_LIMITS[6] == KIT_SPEED_LIMITS[13] == pytest.approx(0.0875)
    assert KIT_SPEED_LIMITS[0] == pytest.approx(3.375) and KIT_SPEED_LIMITS[5] == 7.0


def test_a_jump_is_shortened_and_a_small_step_is_kept() -> None:
    clamp = SpeedClamp(0.9)
    measured = np.zeros(14)
    small = np.full(14, 1e-4)
    assert np.array_equal(clamp(small, measured, 0.06), small)
    jump = measured.copy()
    jump[6] = 0.016  # the gripper 16 mm away in 60 ms: 0.27 m/s, three times its limit
    out = clamp(jump, measured, 0.06)
    assert out[6] == pytest.approx(0.9 * 0.0875 * 0.06 / PEAK_TO_MEAN)
    assert np.array_equal(out[:6], jump[:6])
    assert (clamp.goals, clamp.shortened) == (2, 1)


def test_goals_are_measured_from_the_arms_position() -> None:
    clamp = SpeedClamp(1.0)
    step = KIT_SPEED_LIMITS * 0.06 / PEAK_TO_MEAN
    measured = np.full(14, 0.0125)  # e.g. a gripper squeezing a cube stays at its faces
    for _ in range(3):  # the same measured position: the same shortened goal every time
        out = clamp(np.full(14, 1.0), measured, 0.06)
        np.testing.assert_allclose(out, measured + step)
    assert (clamp.goals, clamp.shortened) == (3, 3)


def test_backwards_jumps_are_shortened_too() -> None:
    out = SpeedClamp(0.5)(np.full(14, -10.0), np.zeros(14), 0.1)
    np.testing.assert_allclose(out, -0.5 * KIT_SPEED_LIMITS * 0.1 / PEAK_TO_MEAN)


@pytest.mark.parametrize("fraction", [0.0, -0.1, 1.5])
def test_the_fraction_is_checked(fraction: float) -> None:
    with pytest.raises(ValueError, match="fraction"):
        SpeedClamp(fraction)
