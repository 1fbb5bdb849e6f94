"""The real arms' speed limits applied to a stream of position goals (``eval --backend wire
--speed_limit_fraction F``).

A policy's consecutive actions can jump, and a goal to reach within ``goal_time`` then asks
for more than a joint's speed limit (the controller faults). ``SpeedClamp`` keeps each goal
within ``F * limit * goal_time / PEAK_TO_MEAN`` of the arm's measured position and counts
the goals it had to shorten.

Docs: docs/rehearsal.md (Measured); why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS

__all__ = ["KIT_SPEED_LIMITS", "PEAK_TO_MEAN", "SpeedClamp"]

#: Peak over mean speed of a quintic rest-to-rest move (15/8): the margin a goal step keeps.
PEAK_TO_MEAN = 1.875

#: The real kit's speed limits in the driver's 14-value order (per arm: joint_0..joint_5
#: in rad/s, then the gripper carriage in m/s; left arm first).
KIT_SPEED_LIMITS: np.ndarray = np.tile(
    [JOINT_VELOCITY_LIMITS[f"joint_{i}"] for i in range(6)]
    + [JOINT_VELOCITY_LIMITS["left_carriage_joint"]],
    2,
)


class SpeedClamp:
    """Shortens goals that would ask the controllers for more than ``fraction`` of the
    speed limits.

    Args:
        fraction: share of the limit allowed, in (0, 1].
        limits: the speed limit of each value (default ``KIT_SPEED_LIMITS``, the kit's 14;
            a single arm's 7: ``KIT_SPEED_LIMITS[:7]``).
    """

    def __init__(self, fraction: float, limits: np.ndarray | None = None) -> None:
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"fraction must be in (0, 1], got {fraction}")
        self.fraction = float(fraction)
        self.limits = KIT_SPEED_LIMITS if limits is None else np.asarray(limits, dtype=float)
        self.shortened = 0
        self.goals = 0

    def __call__(self, goal: np.ndarray, measured: np.ndarray, goal_time: float) -> np.ndarray:
        """``goal`` (14,; as many as ``limits``) moved toward ``measured`` (the arms'
        positions: rad, m) so that no value is further than ``fraction * limit * goal_time /
        PEAK_TO_MEAN`` from it."""
        base = np.asarray(measured, dtype=np.float64)
        reach = self.fraction * self.limits * float(goal_time) / PEAK_TO_MEAN
        out = np.clip(np.asarray(goal, dtype=np.float64), base - reach, base + reach)
        self.goals += 1
        if not np.array_equal(out, goal):
            self.shortened += 1
        return out
