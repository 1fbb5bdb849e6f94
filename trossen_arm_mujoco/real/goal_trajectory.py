"""The arm driver's trajectory toward a goal: what ``set_all_positions(goal, goal_time)``
makes the setpoint of an arm do.

Like the real ``trossen_arm`` driver, each command starts a setpoint trajectory from the
current setpoint (position, velocity, acceleration; continuous across commands) to the goal
over ``goal_time``: above :data:`QUINTIC_MIN_GOAL_TIME` (0.2 s) a quintic (zero velocity and
acceleration at the goal), shorter a linear ramp, zero a step change. Used by the simulated
driver and by in-process evaluation (``KitController``), whose policies send every action
with ``goal_time = GOAL_TIME_FACTOR / fps`` as Trossen's LeRobot plugin does.

Docs: docs/real-kit.md.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GOAL_TIME_FACTOR", "QUINTIC_MIN_GOAL_TIME", "GoalTrajectory"]

#: Above this goal time the setpoint follows a quintic, below a linear ramp (s).
QUINTIC_MIN_GOAL_TIME: float = 0.2

#: A policy's action is sent as a goal reached after this many of its periods
#: (``set_all_positions(goal, GOAL_TIME_FACTOR / fps)``), as the kit's LeRobot plugin does:
#: the next action arrives while the arm is still on its way, so motion stays smooth.
GOAL_TIME_FACTOR: float = 3.0


class GoalTrajectory:
    """Setpoint trajectory from ``(p0, v0, a0)`` to ``(goal, 0, 0)`` over ``duration`` s.

    Args:
        p0: start positions (rad; m), any one shape for all four arrays.
        v0: start velocities (rad/s; m/s).
        a0: start accelerations (rad/s^2; m/s^2).
        goal: goal positions (rad; m).
        duration: the goal time (s): quintic above ``QUINTIC_MIN_GOAL_TIME``, a linear ramp
            below, a step at zero.
    """

    def __init__(
        self, p0: np.ndarray, v0: np.ndarray, a0: np.ndarray, goal: np.ndarray, duration: float
    ) -> None:
        self.goal, self.duration = goal, float(duration)
        self.linear = self.duration <= QUINTIC_MIN_GOAL_TIME
        self.p0 = p0
        if self.linear:
            self.rate = (goal - p0) / duration if duration > 0 else np.zeros_like(goal)
            return
        d, h = self.duration, goal - p0
        c3 = (20 * h - 12 * v0 * d - 3 * a0 * d**2) / (2 * d**3)
        c4 = (-30 * h + 16 * v0 * d + 3 * a0 * d**2) / (2 * d**4)
        c5 = (12 * h - 6 * v0 * d - a0 * d**2) / (2 * d**5)
        self.coef = np.stack([p0, v0, a0 / 2, c3, c4, c5])

    @classmethod
    def hold(cls, position: np.ndarray) -> GoalTrajectory:
        """A trajectory that stays at ``position`` (a fresh arm's setpoint)."""
        p = np.asarray(position, dtype=np.float64).copy()
        return cls(p, np.zeros_like(p), np.zeros_like(p), p, 0.0)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Setpoint position, velocity, acceleration at ``t`` s into the trajectory."""
        zero = np.zeros_like(self.goal)
        if t >= self.duration:
            return self.goal, zero, zero
        if self.linear:
            return self.p0 + self.rate * t, self.rate, zero
        c = self.coef
        pos = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))))
        vel = c[1] + t * (2 * c[2] + t * (3 * c[3] + t * (4 * c[4] + t * 5 * c[5])))
        acc = 2 * c[2] + t * (6 * c[3] + t * (12 * c[4] + t * 20 * c[5]))
        return pos, vel, acc
