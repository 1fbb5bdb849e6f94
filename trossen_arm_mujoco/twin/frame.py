"""One frame of the served world: what a recorder stores of it.

Docs: docs/cli/serve.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Frame"]


@dataclass
class Frame:
    """One frame of the world.

    Attributes:
        time: simulated time at the frame's start (s, since the episode's reset).
        qpos_full, mocap_pos, mocap_quat: the whole state to render the frame's start from.
        qpos, qvel: 16 values in the kit layout (rad, m; rad/s, m/s), at the frame's start.
        env_state: object poses at the frame's start (xyz m + quat wxyz each).
        action: the commanded targets during the frame, 16 values in the kit layout (the
            gripper target in both finger columns).
        reward: the task's reward after the frame; success: the task's success after it.
    """

    time: float
    qpos_full: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    env_state: np.ndarray
    action: np.ndarray
    reward: float = 0.0
    success: bool = False
