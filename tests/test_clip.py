"""clip: numpy's clip ufunc called directly gives np.clip's values."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.clip import _two_ufuncs, clip


def test_clip_equals_np_clip_value_for_value():
    rng = np.random.default_rng(0)
    x = rng.uniform(-3, 3, (50, 7))
    x[3, 2] = np.nan
    low, high = -np.abs(rng.uniform(0, 2, 7)), np.abs(rng.uniform(0, 2, 7))
    for f in (clip, _two_ufuncs):
        got = f(x, low, high)
        np.testing.assert_array_equal(got, np.clip(x, low, high))  # NaN where x is NaN
        assert np.isnan(got[3, 2])
        out = x.copy()
        assert f(out, low, high, out=out) is out
        np.testing.assert_array_equal(out, np.clip(x, low, high))
    assert clip(5.0, -1.0, 1.0) == 1.0


def test_clip_is_numpys_ufunc():
    assert isinstance(clip, np.ufunc) and clip.__name__ == "clip"
