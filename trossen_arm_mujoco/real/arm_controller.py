"""The kit's two arm controllers as a policy meets them: each action is a goal the driver's
trajectory moves toward, and every setpoint of that trajectory passes the controller's
checks.

A policy's action reaches an arm as ``set_all_positions(goal, goal_time=GOAL_TIME_FACTOR /
fps)`` (Trossen's LeRobot plugin): the driver streams the setpoints of
:class:`~.goal_trajectory.GoalTrajectory`, and the controller enters its error state on the
first its checks refuse (:class:`~.controller_checks.InputChecker`). :class:`KitController`
is that path for in-process evaluation: :meth:`KitController.command` starts an action's
trajectory, :meth:`KitController.tick` gives each control tick's checked setpoint and the
first fault. Values are the kit's 14 (``robot.layout.KIT14_LAYOUT``): per arm ``joint_0`` ..
``joint_5`` (rad) and the gripper carriage (m).

Docs: docs/real-kit.md, docs/train-eval.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.real.controller_checks import (
    LABELS,
    POSITION,
    Fault,
    InputChecker,
    JointLimit,
    controller_limits,
)
from trossen_arm_mujoco.real.goal_trajectory import GOAL_TIME_FACTOR, GoalTrajectory
from trossen_arm_mujoco.real.gripper import GRIPPER_INDEX, GRIPPER_MAX

__all__ = [
    "ARM_SIDES",
    "GOAL_TIME_FACTOR",
    "SIDES",
    "VALUE_LABELS",
    "KitController",
    "controller_target",
    "value_labels",
]

#: The arms, in the order of the 14 values.
SIDES: tuple[str, ...] = ("left", "right")
#: The one arm of a single WidowX AI (its 7 values are labelled without a side).
ARM_SIDES: tuple[str, ...] = ("",)


def value_labels(sides: Sequence[str] = SIDES) -> tuple[str, ...]:
    """Label of each value of the arms ``sides`` (``left_joint_0`` .. ``right_gripper``;
    a side ``""``: ``joint_0`` .. ``gripper``), for faults and speed reports."""
    return tuple(f"{s}_{label}" if s else label for s in sides for label in LABELS)


#: Label of each of the 14 values (``left_joint_0`` .. ``right_gripper``), for faults and
#: speed reports.
VALUE_LABELS: tuple[str, ...] = value_labels(SIDES)


def controller_target(position: float, j: int, limit: JointLimit) -> float:
    """What an arm controller aims a joint at for an accepted position command: the command
    clipped to the joint range (the gripper also to ``GRIPPER_MAX``, as the real controller
    clips it).

    Args:
        position: the commanded position (rad; m for the gripper).
        j: the driver value's index, 0..5 the joints, 6 the gripper.
        limit: the value's limits (:func:`~.controller_checks.controller_limits`).
    """
    hi = min(limit.position_max, GRIPPER_MAX) if j == GRIPPER_INDEX else limit.position_max
    return min(max(position, limit.position_min), hi)


class KitController:
    """Both arm controllers of the kit with the driver's trajectory (see the module doc).

    Args:
        limits: the 7 joint limits of each arm (default ``controller_limits()``).
        checks: apply the controller's checks (False: the same trajectory, nothing
            refused: the unconstrained score).
        sides: the arms, in the order of their values: ``SIDES`` (the kit's 14 values,
            default) or ``ARM_SIDES`` (one WidowX AI arm's 7, labelled ``joint_0`` ..
            ``gripper``).

    Attributes:
        fault: the first fault since :meth:`reset` (None while every setpoint passed);
            its ``joint`` is one of :attr:`labels`.
        fault_tick: how many ticks after :meth:`reset` it came (None when no fault).
        peak_fraction: float64 ``(14,)`` (``(7,)`` for one arm) largest speed asked of
            each value since :meth:`reset`, as a fraction of its velocity limit (without
            tolerance).
        labels: the label of each value (``value_labels(sides)``).
    """

    def __init__(
        self,
        limits: Sequence[JointLimit] | None = None,
        checks: bool = True,
        sides: Sequence[str] = SIDES,
    ) -> None:
        lims = list(limits) if limits is not None else controller_limits()
        self.limits = lims
        self.checks = bool(checks)
        self.sides = tuple(sides)
        self.labels = value_labels(self.sides)
        arms = len(self.sides)
        self.checker = InputChecker(lims)
        self._vmax = np.array([lim.velocity_max for lim in lims] * arms)
        # controller_target as bounds, computed once (tick runs every physics step)
        n = len(lims)
        self._low = np.array([lim.position_min for lim in lims] * arms)
        self._high = np.array(
            [controller_target(lim.position_max, j % n, lim) for j, lim in enumerate(lims * arms)]
        )
        self._modes = [POSITION] * len(lims)
        self._trajectory = GoalTrajectory.hold(np.zeros(arms * len(lims)))
        self._t = 0.0
        self._ticks = 0
        self.fault: Fault | None = None
        self.fault_tick: int | None = None
        self.peak_fraction = np.zeros(arms * len(lims))

    def reset(self, measured: np.ndarray) -> None:
        """A fresh episode: the setpoint holds ``measured`` (14,; 7 for one arm), no fault,
        no peak."""
        self._trajectory = GoalTrajectory.hold(np.asarray(measured, dtype=np.float64))
        self._t, self._ticks = 0.0, 0
        self.fault, self.fault_tick = None, None
        self.peak_fraction[:] = 0.0

    def command(self, goal: np.ndarray, goal_time: float) -> None:
        """Start moving toward ``goal`` (14,) from the current setpoint, arriving after
        ``goal_time`` s (the driver's ``set_all_positions``)."""
        p, v, a = self._trajectory.sample(self._t)
        goal = np.asarray(goal, dtype=np.float64)
        self._trajectory = GoalTrajectory(p, v, a, goal.copy(), float(goal_time))
        self._t = 0.0

    def tick(self, dt: float) -> tuple[np.ndarray, Fault | None]:
        """Advance the trajectory ``dt`` s; the setpoint the arms aim at (14,: clipped as
        :func:`controller_target`) and the fault this setpoint raised (None: accepted, or
        checks off). After a fault, ``fault`` keeps the first one."""
        self._t += dt
        self._ticks += 1
        pos, vel, _ = self._trajectory.sample(self._t)
        with np.errstate(invalid="ignore"):
            np.fmax(self.peak_fraction, np.abs(vel) / self._vmax, out=self.peak_fraction)
        fault = self._check(pos, vel) if self.checks else None
        if fault is not None and self.fault is None:
            self.fault, self.fault_tick = fault, self._ticks
        target = np.clip(np.nan_to_num(pos, nan=0.0, posinf=0.0, neginf=0.0), self._low, self._high)
        return target, fault

    def peak_fractions(self) -> dict[str, float]:
        """:attr:`peak_fraction` by value label (``left_joint_0`` ... ``right_gripper``; one
        arm: ``joint_0`` ... ``gripper``)."""
        return {k: float(v) for k, v in zip(self.labels, self.peak_fraction)}

    def _check(self, pos: np.ndarray, vel: np.ndarray) -> Fault | None:
        n = len(self.limits)
        for a, side in enumerate(self.sides):
            values = [(float(pos[a * n + j]), float(vel[a * n + j]), 0.0) for j in range(n)]
            fault = self.checker.check(self._modes, values)
            if fault is not None and side:
                return dataclasses.replace(
                    fault, joint=f"{side}_{fault.joint}", reason=f"{side} arm {fault.reason}"
                )
            if fault is not None:
                return fault
        return None
