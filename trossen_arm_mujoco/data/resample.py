"""A recorded episode at another rate: the times, and the rows at those times.

A source episode of ``T`` steps at period ``dt`` has its observation ``j`` at time ``j*dt``
and its action ``j`` as the joint target for the end of step ``j`` (time ``(j+1)*dt``). At
``fps`` F the frame ``k`` is at ``t_k = k/F``:

- vector observations are interpolated linearly at ``t_k`` (``observation_times``);
- images take the source frame nearest ``t_k`` (``nearest_rows``);
- the action of frame ``k`` is the source action trajectory at ``t_k + 1/F - dt``
  (``action_times``), so that holding it for one frame reaches where the source reached at
  ``t_{k+1}``;
- a per-step scalar (reward) takes the source step whose period holds the end of frame
  ``k`` (``step_rows``).

A frame exists while every time it needs lies within the source: ``num_frames``.
"""

from __future__ import annotations

import math

import numpy as np


def num_frames(num_steps: int, dt: float, fps: float) -> int:
    """Frames at ``fps`` of a ``num_steps``-step episode at period ``dt``: those whose
    observation time and action time lie within the recording."""
    if num_steps < 1:
        return 0
    span = (num_steps - 1) * dt  # last observation and last action (shifted) sample
    # action time of frame k: k/F + 1/F - dt <= span  <=>  k <= (span + dt) F - 1
    last_obs = math.floor(span * fps + 1e-9)
    last_act = math.floor((span + dt) * fps - 1 + 1e-9)
    return max(0, min(last_obs, last_act) + 1)


def observation_times(frames: int, fps: float) -> np.ndarray:
    """``t_k = k / fps`` for ``k < frames`` (s)."""
    return np.arange(frames) / float(fps)


def action_times(frames: int, fps: float, dt: float) -> np.ndarray:
    """Source-action time of each frame's action: ``t_k + 1/fps - dt`` (s)."""
    return observation_times(frames, fps) + (1.0 / float(fps) - dt)


def interpolate_rows(values: np.ndarray, dt: float, times: np.ndarray) -> np.ndarray:
    """Rows of ``values`` ((T, D), sampled at ``j*dt``) linearly interpolated at ``times``
    (held at the ends); float64 (K, D)."""
    v = np.asarray(values, dtype=float)
    pos = np.clip(np.asarray(times, dtype=float) / dt, 0.0, len(v) - 1)
    lo = np.floor(pos + 1e-9).astype(int)
    lo = np.minimum(lo, len(v) - 1)
    hi = np.minimum(lo + 1, len(v) - 1)
    frac = np.clip(pos - lo, 0.0, 1.0)[:, None]
    return v[lo] * (1.0 - frac) + v[hi] * frac


def nearest_rows(num_steps: int, dt: float, times: np.ndarray) -> np.ndarray:
    """Index of the source sample nearest each time (ties to the earlier one)."""
    pos = np.asarray(times, dtype=float) / dt
    return np.clip(np.ceil(pos - 0.5 - 1e-9).astype(int), 0, num_steps - 1)


def step_rows(num_steps: int, dt: float, fps: float, frames: int) -> np.ndarray:
    """Index of the source step whose period ``(j*dt, (j+1)*dt]`` holds the end of each
    frame (``(k+1)/fps``), for per-step scalars such as the reward."""
    ends = (np.arange(frames) + 1) / float(fps)
    return np.clip(np.ceil(ends / dt - 1e-9).astype(int) - 1, 0, num_steps - 1)


def normalize_quaternions(poses: np.ndarray) -> np.ndarray:
    """Rows of object poses (7 per object: xyz + quat wxyz) with each quaternion rescaled to
    unit length (in place; returned)."""
    n = poses.shape[-1] // 7
    for i in range(n):
        q = poses[..., 7 * i + 3 : 7 * i + 7]
        norm = np.linalg.norm(q, axis=-1, keepdims=True)
        np.divide(q, np.where(norm > 0, norm, 1.0), out=q)
    return poses


def resample_actions(actions: np.ndarray, dt: float, fps: float, frames: int) -> np.ndarray:
    """A joint-target trajectory ((T, D) at period ``dt``) as ``frames`` targets at ``fps``
    (the action rule above; the last target is held past the recording's end)."""
    return interpolate_rows(actions, dt, action_times(frames, fps, dt))
