"""``eval.speed_clamp``: goals shortened to a share of the real speed limits."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.eval.speed_clamp import KIT_SPEED_LIMITS, SpeedClamp


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
    assert out[6] == pytest.approx(0.9 * 0.0875 * 0.06)
    assert np.array_equal(out[:6], jump[:6])
    assert (clamp.goals, clamp.shortened) == (2, 1)


def test_backwards_jumps_are_shortened_too() -> None:
    out = SpeedClamp(0.5)(np.full(14, -10.0), np.zeros(14), 0.1)
    np.testing.assert_allclose(out, -0.5 * KIT_SPEED_LIMITS * 0.1)


@pytest.mark.parametrize("fraction", [0.0, -0.1, 1.5])
def test_the_fraction_is_checked(fraction: float) -> None:
    with pytest.raises(ValueError, match="fraction"):
        SpeedClamp(fraction)
