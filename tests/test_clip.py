"""clip: np.clip's values through two public ufunc calls."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.clip import clip


def test_clip_equals_np_clip_value_for_value():
    rng = np.random.default_rng(0)
    x = rng.uniform(-3, 3, (50, 7))
    x[3, 2] = np.nan
    low, high = -np.abs(rng.uniform(0, 2, 7)), np.abs(rng.uniform(0, 2, 7))
    got = clip(x, low, high)
    np.testing.assert_array_equal(got, np.clip(x, low, high))  # NaN where x is NaN
    assert np.isnan(got[3, 2])
    out = x.copy()
    assert clip(out, low, high, out=out) is out
    np.testing.assert_array_equal(out, np.clip(x, low, high))


def test_scalars_and_mixed_precision():
    assert clip(5.0, -1.0, 1.0) == 1.0 and clip(0.02, 0.0, 0.044) == 0.02
    vec = np.array([-2.0, 0.5, 2.0], dtype=np.float32)
    clip(vec, -np.ones(3), np.ones(3), out=vec)  # float64 bounds into a float32 vector
    assert vec.dtype == np.float32
    np.testing.assert_array_equal(vec, [-1.0, 0.5, 1.0])
