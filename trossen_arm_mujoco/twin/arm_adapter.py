"""One arm of the shared kit world, as the object ``trossen_arm_sim``'s server drives.

The server of one arm (:mod:`.arm_server`) hands every robot input to
:meth:`ArmAdapter.handle_input` and reads :meth:`ArmAdapter.read_joint_outputs` for every
answer. The 7 values are the driver's: ``joint_0`` .. ``joint_5`` (rad) and the gripper
carriage's travel from closed (m, 0 .. 0.044). Modes per joint (``trossen_arm.Mode``):
``position``, ``velocity``, ``external_effort``, ``effort`` (N m; N for the gripper) and
``idle`` (the joints hold still). Also the upstream interface, so that
``trossen_arm_sim.TrossenArmSimServer`` itself can serve it.

Docs: docs/cli/serve.md; the modes in full: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.real.arm_controller import controller_target
from trossen_arm_mujoco.real.controller_checks import (
    EFFORT,
    EXTERNAL_EFFORT,
    IDLE,
    JOINT_LIMIT_EXCEEDED,
    LABELS,
    POSITION,
    UNITS,
    VELOCITY,
    Fault,
    InputChecker,
    JointLimit,
    controller_limits,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_INDEX, GRIPPER_MAX
from trossen_arm_mujoco.twin.kit_world import KitWorld

__all__ = ["MAX_VELOCITY_DT", "OUTPUT_TEMPERATURE_C", "ArmAdapter"]

#: Rotor and driver temperature reported for every joint (C).
OUTPUT_TEMPERATURE_C: float = 40.0

#: Longest time step (s) a velocity command is integrated over: after a gap in the robot
#: inputs, the arm does not jump by the whole gap's worth of motion.
MAX_VELOCITY_DT: float = 0.01


class ArmAdapter:
    """The arm ``side`` (``"left"`` or ``"right"``) of ``world``; see the module doc.

    Args:
        world: the shared kit world.
        side: which arm.
        limits: its 7 joint limits (default ``real.controller_checks.controller_limits()``).
    """

    num_joints = 7

    def __init__(
        self, world: KitWorld, side: str, limits: Sequence[JointLimit] | None = None
    ) -> None:
        self.world, self.side = world, side
        self.checker = InputChecker(limits if limits is not None else controller_limits())
        self._last_input: float | None = None
        # the joints' hard stops: a reported position never lies beyond them (see output_table)
        stops = controller_limits()
        self._stop_low = np.array([lim.position_min for lim in stops], dtype="<f4")
        self._stop_high = np.array([lim.position_max for lim in stops], dtype="<f4")
        with world.lock:
            world.arms[side].limits = self.limits  # the world checks the motion too

    # -- limits ---------------------------------------------------------------------------
    @property
    def limits(self) -> list[JointLimit]:
        """The joint limits the inputs are checked against."""
        return self.checker.limits

    def set_limits(self, limits: Sequence[JointLimit]) -> None:
        """Replace the joint limits (a client's ``set_joint_limits``)."""
        self.checker.set_limits(limits)
        with self.world.lock:
            self.world.arms[self.side].limits = self.limits

    @property
    def joint_limits(self) -> list[tuple[float, float]]:
        """``(min, max)`` position per joint (rad, m)."""
        return [(lim.position_min, lim.position_max) for lim in self.limits]

    # -- inputs ---------------------------------------------------------------------------
    def handle_input(
        self, modes: Sequence[int], values: Sequence[Sequence[float]], now: float
    ) -> Fault | None:
        """Check one robot input and, when it is valid, apply it; returns the fault, if any
        (nothing is applied then).

        Args:
            modes: mode value per joint.
            values: per joint ``(position, velocity, effort)`` (rad, rad/s, N m; gripper m,
                m/s, N).
            now: receive time (s, monotonic).
        """
        fault = self.checker.check(modes, values)
        if fault is not None:
            return fault
        dt = 0.0 if self._last_input is None else min(now - self._last_input, MAX_VELOCITY_DT)
        self._last_input = now
        with self.world.lock:
            arm = self.world.arms[self.side]
            for j, (mode, (pos, vel, eff)) in enumerate(zip(modes, values)):
                lim = self.limits[j]
                if mode == POSITION:
                    arm.target[j] = controller_target(pos, j, lim)
                elif mode == VELOCITY:
                    goal = arm.target[j] + vel * dt
                    tol = lim.position_tolerance
                    if not lim.position_min - tol <= goal <= lim.position_max + tol:
                        arm.modes[:] = IDLE
                        return Fault(
                            JOINT_LIMIT_EXCEEDED,
                            f"{LABELS[j]}: velocity command drove the joint to {goal:.4g} "
                            f"{UNITS[j]}, outside its limits [{lim.position_min:.4g}, "
                            f"{lim.position_max:.4g}] {UNITS[j]}",
                        )
                    # within the tolerance the target may pass the limit (the robot layer
                    # clips the control), so that driving on into it faults
                    arm.target[j] = min(goal, GRIPPER_MAX) if j == GRIPPER_INDEX else goal
                elif mode in (EXTERNAL_EFFORT, EFFORT):
                    arm.effort[j] = eff
                arm.modes[j] = mode
        return None

    def apply_joint_commands(self, modes: Sequence[int], positions: Sequence[float]) -> None:
        """Upstream's interface: position commands only (other modes get zero values)."""
        values = [(float(p), 0.0, 0.0) for p in positions]
        self.handle_input([int(m) for m in modes], values, time.monotonic())

    def idle(self) -> None:
        """All joints idle (the error state, or no client): they stop where their
        rate-limited setpoint is and hold there."""
        with self.world.lock:
            arm = self.world.arms[self.side]
            arm.modes[:] = IDLE
            arm.target[:] = self.world.setpoint(self.side)
        self._last_input = None

    def set_modes(self, modes: Sequence[int]) -> None:
        """Modes configured by the client (``set_all_modes``): a joint entering position
        or velocity mode starts from where it is, not from a stale target."""
        with self.world.lock:
            arm = self.world.arms[self.side]
            measured = self.world.measured(self.side)
            for j, mode in enumerate(modes):
                if mode != arm.modes[j] and mode in (POSITION, VELOCITY):
                    arm.target[j] = measured[j]
                arm.modes[j] = mode
        self._last_input = None

    # -- outputs --------------------------------------------------------------------------
    def output_table(self) -> np.ndarray:
        """The robot output of the 7 values as little-endian float32 ``(7, 6)``, the wire
        layout of ``JointOutput``: position (within the joint's hard stops: MuJoCo's soft
        joint limits let a joint pressed against its stop sink past it, the closed gripper by
        about 1 mm, which a real encoder never reports and the controller refuses as a
        command), velocity; effort: the actuator force (N m / N;
        it carries the gravity compensation) plus any applied effort; external effort: the
        constraint force on the joint (contacts, joint limits; for the gripper summed over
        both fingers, whose coupling cancels); rotor and driver temperature (40 C)."""
        table = np.full((7, 6), OUTPUT_TEMPERATURE_C, dtype="<f4")
        w, side = self.world, self.side
        with w.lock:
            d, dof = w.data, w.dadr[side]
            table[:, 0] = np.clip(d.qpos[w.qadr[side]], self._stop_low, self._stop_high)
            table[:, 1] = d.qvel[dof]
            table[:, 2] = d.actuator_force[w.act[side]] + d.qfrc_applied[dof]
            table[:, 3] = d.qfrc_constraint[dof]
            table[6, 3] += d.qfrc_constraint[w.twin_dadr[side]]
        return table

    def read_joint_outputs(self) -> list:
        """:meth:`output_table` as ``JointOutput`` objects (upstream's interface)."""
        from trossen_arm_sim.protocol import JointOutput

        return [JointOutput(*map(float, row)) for row in self.output_table()]
