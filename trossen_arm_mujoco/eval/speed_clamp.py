"""The real arms' speed limits applied to a stream of position goals (``eval --backend wire
--speed_limit_fraction F``).

A learned policy's consecutive actions can jump (ACT's chunk boundaries, a missed control
period): sent to an arm controller as a goal to reach within ``goal_time``, such a jump asks
for more than the joint's speed limit and the controller faults (the served kit, like the
real one, reports "feedforward velocity ... exceeds the velocity limit"). ``SpeedClamp``
moves each goal toward the policy's action by at most ``F`` times the limit times
``goal_time`` from the arm's measured position, so the controller is never asked for more
than ``F`` of its limit, and counts the goals it had to shorten.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS

__all__ = ["KIT_SPEED_LIMITS", "SpeedClamp"]

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
    """

    def __init__(self, fraction: float) -> None:
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"fraction must be in (0, 1], got {fraction}")
        self.fraction = float(fraction)
        self.shortened = 0
        self.goals = 0

    def __call__(self, goal: np.ndarray, measured: np.ndarray, goal_time: float) -> np.ndarray:
        """``goal`` (14,) moved toward ``measured`` (14,, the arms' positions) so that no
        value is further than ``fraction * limit * goal_time`` (rad or m) from it."""
        reach = self.fraction * KIT_SPEED_LIMITS * float(goal_time)
        out = np.clip(np.asarray(goal, dtype=np.float64), measured - reach, measured + reach)
        self.goals += 1
        if not np.array_equal(out, goal):
            self.shortened += 1
        return out
