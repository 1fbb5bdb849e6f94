"""Feature statistics of a LeRobot dataset: per episode, and pooled over the dataset.

Every feature gets ``min``, ``max``, ``mean``, ``std``, ``count`` and the quantiles
``q01 q10 q50 q90 q99`` (see :data:`.lerobot_format.STAT_NAMES`):

- vectors ``(T, D)``: per component, shape ``(D,)``; scalars ``(T,)``: shape ``(1,)``;
  ``count`` is ``[T]``.
- images: per colour channel over the pixels of a sample of frames, scaled to [0, 1],
  shape ``(3, 1, 1)``; ``count`` is the number of sampled frames.

Dataset statistics pool the episodes': count-weighted mean, pooled variance, overall
min/max, and count-weighted means of the episode quantiles.

Docs: docs/datasets.md (The LeRobot export).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.export.lerobot_format import QUANTILES, STAT_NAMES

__all__ = [
    "IMAGE_DOWNSAMPLE_FROM",
    "IMAGE_STATS_SIDE",
    "MAX_IMAGE_SAMPLES",
    "MIN_IMAGE_SAMPLES",
    "Stats",
    "aggregate",
    "array_stats",
    "downsample",
    "image_sample_indices",
    "image_stats",
    "to_lists",
]

Stats = dict[str, np.ndarray]

#: Frames sampled per episode for image statistics: all up to this many, then T**0.75.
MIN_IMAGE_SAMPLES = 100
MAX_IMAGE_SAMPLES = 10_000
#: Images with a side at least this long are subsampled to about ``IMAGE_STATS_SIDE`` pixels.
IMAGE_DOWNSAMPLE_FROM = 300
IMAGE_STATS_SIDE = 150


def _describe(values: np.ndarray, count: int) -> Stats:
    """Stats over axis 0 of ``values`` ``(N, D)``; ``count`` is what ``count`` reports."""
    values = np.asarray(values, dtype=np.float64)
    stats = {
        "min": values.min(axis=0),
        "max": values.max(axis=0),
        "mean": values.mean(axis=0),
        "std": values.std(axis=0),
        "count": np.array([count], dtype=np.int64),
    }
    quantiles = np.quantile(values, QUANTILES, axis=0)
    for name, q in zip(STAT_NAMES[5:], quantiles, strict=True):
        stats[name] = q
    return stats


def array_stats(values: np.ndarray) -> Stats:
    """Stats of a per-frame feature: ``(T,)`` scalars or ``(T, D)`` vectors (T >= 1)."""
    values = np.asarray(values)
    if values.ndim == 1:
        values = values[:, None]
    return _describe(values.astype(np.float64), values.shape[0])


def image_sample_indices(num_frames: int) -> np.ndarray:
    """Frames of an episode used for image statistics: evenly spread, all when few."""
    if num_frames <= MIN_IMAGE_SAMPLES:
        n = num_frames
    else:
        n = max(MIN_IMAGE_SAMPLES, min(int(num_frames**0.75), MAX_IMAGE_SAMPLES))
    return np.unique(np.round(np.linspace(0, num_frames - 1, n)).astype(np.int64))


def downsample(frame: np.ndarray) -> np.ndarray:
    """A large frame ``(H, W, 3)`` subsampled by a whole factor for statistics."""
    h, w = frame.shape[:2]
    if max(h, w) < IMAGE_DOWNSAMPLE_FROM:
        return frame
    step = max(1, max(h, w) // IMAGE_STATS_SIDE)
    return frame[::step, ::step]


def image_stats(frames: Sequence[np.ndarray]) -> Stats:
    """Per-channel stats of sampled uint8 frames ``(H, W, 3)``, in [0, 1], shape (3, 1, 1).

    Computed from each channel's 256-level histogram: exact (quantiles interpolate linearly
    between pixel values, as ``np.quantile``) and linear in the number of pixels.
    """
    pixels = np.concatenate([np.asarray(f, dtype=np.uint8).reshape(-1, 3) for f in frames])
    levels = np.arange(256) / 255.0
    per_channel = []
    for c in range(3):
        hist = np.bincount(pixels[:, c], minlength=256)
        n = int(hist.sum())
        present = np.flatnonzero(hist)
        mean = float(hist @ levels) / n
        stats = {
            "min": levels[present[0]],
            "max": levels[present[-1]],
            "mean": mean,
            "std": np.sqrt(float(hist @ np.square(levels - mean)) / n),
        }
        ends = np.cumsum(hist)  # pixel ranks [ends[v-1], ends[v]) hold level v
        for name, q in zip(STAT_NAMES[5:], QUANTILES, strict=True):
            rank = q * (n - 1)
            lo, hi = np.searchsorted(ends, [np.floor(rank), np.ceil(rank)], side="right")
            stats[name] = levels[lo] + (rank - np.floor(rank)) * (levels[hi] - levels[lo])
        per_channel.append(stats)
    out: Stats = {
        name: np.array([ch[name] for ch in per_channel], dtype=np.float64).reshape(3, 1, 1)
        for name in per_channel[0]
    }
    out["count"] = np.array([len(frames)], dtype=np.int64)
    return {name: out[name] for name in STAT_NAMES}


def aggregate(episode_stats: Sequence[Stats]) -> Stats:
    """Dataset stats of one feature from its per-episode stats (see the module docstring)."""
    counts = np.array([s["count"][0] for s in episode_stats], dtype=np.float64)
    total = counts.sum()
    shape = (-1,) + (1,) * (np.asarray(episode_stats[0]["mean"]).ndim)
    w = (counts / total).reshape(shape)
    means = np.stack([s["mean"] for s in episode_stats])
    mean = (w * means).sum(axis=0)
    variances = np.stack([np.square(s["std"]) for s in episode_stats])
    var = (w * (variances + np.square(means - mean))).sum(axis=0)
    out: Stats = {
        "min": np.min(np.stack([s["min"] for s in episode_stats]), axis=0),
        "max": np.max(np.stack([s["max"] for s in episode_stats]), axis=0),
        "mean": mean,
        "std": np.sqrt(np.maximum(var, 0.0)),
        "count": np.array([int(total)], dtype=np.int64),
    }
    for name in STAT_NAMES[5:]:
        out[name] = (w * np.stack([s[name] for s in episode_stats])).sum(axis=0)
    return out


def to_lists(stats: Stats) -> dict[str, list]:
    """Stats as nested lists (JSON, parquet), in :data:`STAT_NAMES` order."""
    return {name: np.asarray(stats[name]).tolist() for name in STAT_NAMES}
