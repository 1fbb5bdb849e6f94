"""Feature statistics of the LeRobot export: per episode, pooled, images."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.export import lerobot_stats as st
from trossen_arm_mujoco.export.lerobot_format import STAT_NAMES, FileIndex


def test_pooled_stats_equal_stats_of_all_frames():
    rng = np.random.default_rng(0)
    parts = [rng.normal(i, 1 + i, size=(n, 16)) for i, n in enumerate((5, 40, 13))]
    pooled = st.aggregate([st.array_stats(p) for p in parts])
    direct = st.array_stats(np.concatenate(parts))
    assert list(pooled) == list(STAT_NAMES)
    for name in ("min", "max", "mean", "std", "count"):
        assert np.allclose(pooled[name], direct[name]), name
    assert pooled["q50"].shape == (16,)


def test_scalar_and_vector_shapes():
    stats = st.array_stats(np.array([0.0, 1.0, 2.0, 3.0]))
    assert {k: v.shape for k, v in stats.items()} == {k: (1,) for k in STAT_NAMES}
    assert stats["mean"][0] == 1.5 and stats["count"][0] == 4
    assert np.allclose(stats["q50"], 1.5)
    assert st.array_stats(np.array([True, False, False, False]))["mean"][0] == 0.25


def test_image_stats_per_channel_in_unit_range():
    frame = np.zeros((6, 8, 3), np.uint8)
    frame[..., 0], frame[..., 2] = 255, 51
    stats = st.image_stats([frame, frame])
    assert stats["mean"].shape == (3, 1, 1) and stats["count"].tolist() == [2]
    assert np.allclose(stats["mean"].ravel(), [1.0, 0.0, 0.2])
    assert np.allclose(stats["std"], 0.0)


def test_image_stats_from_histograms_equal_direct_stats():
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, size=(7, 9, 3), dtype=np.uint8) for _ in range(3)]
    frames.append(np.full((7, 9, 3), 17, np.uint8))
    stats = st.image_stats(frames)
    pixels = np.concatenate([f.reshape(-1, 3) for f in frames]) / 255.0
    direct = st.array_stats(pixels)
    for name in STAT_NAMES:
        if name != "count":
            assert np.allclose(stats[name].ravel(), direct[name]), name
    assert stats["count"].tolist() == [4]


def test_image_sampling_and_downsampling():
    assert st.image_sample_indices(7).tolist() == list(range(7))
    idx = st.image_sample_indices(600)
    assert len(idx) == 121 and idx[0] == 0 and idx[-1] == 599  # 600 ** 0.75
    assert st.downsample(np.zeros((48, 64, 3))).shape == (48, 64, 3)
    assert st.downsample(np.zeros((480, 640, 3))).shape == (120, 160, 3)  # every 4th pixel


def test_file_index_rolls_into_the_next_chunk():
    assert FileIndex(0, 0).next(3) == FileIndex(0, 1)
    assert FileIndex(0, 2).next(3) == FileIndex(1, 0)
    assert FileIndex(2, 7).path("c{chunk_index:03d}/f{file_index:03d}") == "c002/f007"
