"""Joint limits of a served arm, and the input checks that put it in the controller's error state.

A real arm controller refuses robot inputs it must not follow: it enters an error state,
idles its joints and answers every request with that state, so the ``trossen_arm`` driver
raises on its next call, until ``configure(..., clear_error=True)`` clears it. The served
arm does the same, for these inputs (:class:`InputChecker`, one per arm, checked in this
order on every robot input):

- any non-finite value: ``ROBOT_INPUT_INFINITE``;
- position mode: a position command outside ``[position_min - position_tolerance,
  position_max + position_tolerance]``, or a feedforward velocity (the speed of the
  driver's interpolated trajectory) beyond ``velocity_max + velocity_tolerance``:
  ``JOINT_LIMIT_EXCEEDED``;
- velocity mode: a velocity command beyond ``velocity_max + velocity_tolerance``:
  ``JOINT_LIMIT_EXCEEDED`` (the integrated position is checked by the arm, see
  :mod:`.arm_adapter`);
- effort modes (``external_effort``, ``effort``): an effort beyond ``effort_max +
  effort_tolerance``: ``JOINT_LIMIT_EXCEEDED``.

And one check of the motion itself (:func:`lag_fault`, run by the world every control
tick): the robot layer moves each joint's setpoint toward its target at most at the
joint's speed limit; a target running ahead of it by more than :data:`SETPOINT_LAG_S` of
motion at ``velocity_max + velocity_tolerance`` (a ``goal_time=0`` jump, a trajectory
faster than the limit) is ``JOINT_LIMIT_EXCEEDED``, as the real arm faults on the speed it
would reach. It is measured in simulated time, not from when commands arrive, and only
while the world keeps real time (``pacer.Pacer.on_time``): a world running late sees every
trajectory of the client's wall clock too fast, so a busy machine does not trip it.

Limits (:func:`served_limits`), per driver value (6 joints in rad, gripper carriage in m):
position ranges of the arm's MJCF (the gripper 0 .. 0.044 m, the MJCF carriage travel);
position tolerances ``real.validate.POSITION_TOLERANCE`` (0.01 rad, 0.001 m); velocity
limits of the URDF (``robot.configs.JOINT_VELOCITY_LIMITS``: 3.375 / 7.0 rad/s, 0.0875
m/s) with a tolerance of :data:`VELOCITY_TOLERANCE_FRACTION` of each; effort limits of the
URDF (:data:`EFFORT_LIMITS`: 27 / 7 N m, 400 N) with :data:`EFFORT_TOLERANCE_FRACTION`.
The driver reads them with ``get_joint_limits()``; a client may replace them with
``set_joint_limits()``, as on the real controller, and the checks then use its values.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import astuple, dataclass

import numpy as np

from trossen_arm_mujoco.real.validate import POSITION_TOLERANCE, ArmLimits
from trossen_arm_mujoco.twin.commands import EFFORT, EXTERNAL_EFFORT, POSITION, VELOCITY

__all__ = [
    "EFFORT_LIMITS",
    "EFFORT_TOLERANCE_FRACTION",
    "JOINT_LIMIT_EXCEEDED",
    "LABELS",
    "ROBOT_INPUT_INFINITE",
    "SETPOINT_LAG_S",
    "UNITS",
    "VELOCITY_TOLERANCE_FRACTION",
    "Fault",
    "InputChecker",
    "JointLimit",
    "lag_fault",
    "lag_fault_of",
    "pack_limits",
    "served_limits",
    "unpack_limits",
]

#: Effort limits of the 7 driver values (URDF ``<limit effort>``): N m for joint_0..5, N for
#: the gripper carriage.
EFFORT_LIMITS: tuple[float, ...] = (27.0, 27.0, 27.0, 7.0, 7.0, 7.0, 400.0)

#: Velocity tolerance as a fraction of each velocity limit.
VELOCITY_TOLERANCE_FRACTION: float = 0.1

#: Effort tolerance as a fraction of each effort limit.
EFFORT_TOLERANCE_FRACTION: float = 0.05

#: How far a target may run ahead of the rate-limited setpoint, in seconds of motion at
#: the joint's speed limit (plus tolerance): 0.2 s is 0.75 rad for joint_0..2, 1.6 rad for
#: joint_3..5, 19 mm for the gripper. A client that stalls (a busy machine) and then sends
#: its trajectory's current point jumps too: 0.2 s keeps a stall of a few tenths of a
#: second at moderate speed from faulting the arm (0.15 s faulted a gripper move once on a
#: machine loaded 3x over its cores).
SETPOINT_LAG_S: float = 0.2

#: Byte layout of one joint limit on the wire: 7 little-endian floats.
_LIMIT_STRUCT = struct.Struct("<7f")

#: ``trossen_arm_sim.protocol.ErrorState`` values of the faults raised here.
JOINT_LIMIT_EXCEEDED, ROBOT_INPUT_INFINITE = 15, 16

#: Labels of the 7 driver values, for messages.
LABELS: tuple[str, ...] = (*(f"joint_{i}" for i in range(6)), "gripper")
UNITS: tuple[str, ...] = ("rad",) * 6 + ("m",)


@dataclass
class JointLimit:
    """Limits of one joint, as ``trossen_arm.JointLimit`` (rad, rad/s, N m; gripper m,
    m/s, N)."""

    position_min: float
    position_max: float
    position_tolerance: float
    velocity_max: float
    velocity_tolerance: float
    effort_max: float
    effort_tolerance: float


@dataclass(frozen=True)
class Fault:
    """A reason to enter the error state: the ``ErrorState`` value and one line."""

    state: int
    reason: str


def served_limits(arm: ArmLimits | None = None) -> list[JointLimit]:
    """The 7 joint limits of a served arm (see the module doc)."""
    arm = arm if arm is not None else ArmLimits.from_mjcf()
    out = []
    for j in range(7):
        vmax, emax = float(arm.velocity[j]), EFFORT_LIMITS[j]
        out.append(
            JointLimit(
                position_min=float(arm.driver_lower[j]),
                position_max=float(arm.driver_upper[j]),
                position_tolerance=POSITION_TOLERANCE[UNITS[j]],
                velocity_max=vmax,
                velocity_tolerance=VELOCITY_TOLERANCE_FRACTION * vmax,
                effort_max=emax,
                effort_tolerance=EFFORT_TOLERANCE_FRACTION * emax,
            )
        )
    return out


def pack_limits(limits: Sequence[JointLimit]) -> bytes:
    """The ``JOINT_LIMITS`` configuration payload (7 floats per joint)."""
    return b"".join(_LIMIT_STRUCT.pack(*astuple(lim)) for lim in limits)


def unpack_limits(payload: bytes, num_joints: int) -> list[JointLimit]:
    """Parse a ``JOINT_LIMITS`` payload; ``ValueError`` unless it holds ``num_joints``
    limits of finite values with ``position_min <= position_max``."""
    if len(payload) != num_joints * _LIMIT_STRUCT.size:
        raise ValueError(
            f"joint limits payload has {len(payload)} bytes, expected "
            f"{num_joints * _LIMIT_STRUCT.size}"
        )
    size = _LIMIT_STRUCT.size
    limits = [
        JointLimit(*_LIMIT_STRUCT.unpack(payload[i * size : (i + 1) * size]))
        for i in range(num_joints)
    ]
    for lim in limits:
        if not all(math.isfinite(v) for v in astuple(lim)) or lim.position_min > lim.position_max:
            raise ValueError(f"invalid joint limit {lim}")
    return limits


def lag_fault(j: int, gap: float, limit: JointLimit) -> Fault | None:
    """The fault of a target ``gap`` (rad, m) ahead of joint ``j``'s setpoint, or None."""
    allowed = (limit.velocity_max + limit.velocity_tolerance) * SETPOINT_LAG_S
    if gap <= allowed:
        return None
    return Fault(
        JOINT_LIMIT_EXCEEDED,
        f"{LABELS[j]}: the target runs {gap:.4g} {UNITS[j]} ahead of the setpoint, more than "
        f"{SETPOINT_LAG_S:g} s at the velocity limit {limit.velocity_max:.4g} {UNITS[j]}/s "
        f"(a jump or a trajectory too fast for the joint)",
    )


def lag_fault_of(
    modes: np.ndarray, target: np.ndarray, setpoint: np.ndarray, limits: Sequence[JointLimit]
) -> Fault | None:
    """The first :func:`lag_fault` of an arm's joints in position or velocity mode."""
    moving = (modes == POSITION) | (modes == VELOCITY)
    if not moving.any():
        return None
    gap = np.abs(target - setpoint)
    for j in np.flatnonzero(moving):
        fault = lag_fault(int(j), float(gap[j]), limits[j])
        if fault is not None:
            return fault
    return None


class InputChecker:
    """Checks the robot inputs of one arm against its limits (see the module doc)."""

    def __init__(self, limits: Sequence[JointLimit]) -> None:
        self.limits = list(limits)

    def set_limits(self, limits: Sequence[JointLimit]) -> None:
        """Use ``limits`` from now on (a client's ``set_joint_limits``)."""
        self.limits = list(limits)

    def check(self, modes: Sequence[int], values: Sequence[Sequence[float]]) -> Fault | None:
        """The first fault of one robot input, or None.

        Args:
            modes: mode value per joint.
            values: per joint ``(position, velocity, effort)`` as parsed.
        """
        for j, vals in enumerate(values):
            if not all(math.isfinite(v) for v in vals):
                return Fault(
                    ROBOT_INPUT_INFINITE,
                    f"{LABELS[j]}: robot input with a non-finite value {list(vals)}",
                )
        for j, (mode, (pos, vel, eff)) in enumerate(zip(modes, values)):
            lim, unit, name = self.limits[j], UNITS[j], LABELS[j]
            vmax = lim.velocity_max + lim.velocity_tolerance
            if mode == POSITION:
                lo = lim.position_min - lim.position_tolerance
                hi = lim.position_max + lim.position_tolerance
                if not lo <= pos <= hi:
                    return Fault(
                        JOINT_LIMIT_EXCEEDED,
                        f"{name}: position command {pos:.4g} {unit} is outside the joint "
                        f"limits [{lim.position_min:.4g}, {lim.position_max:.4g}] {unit} "
                        f"(tolerance {lim.position_tolerance:g} {unit})",
                    )
                if abs(vel) > vmax:
                    return self._too_fast(j, "feedforward velocity", abs(vel))
            elif mode == VELOCITY and abs(vel) > vmax:
                return self._too_fast(j, "velocity command", abs(vel))
            elif mode in (EXTERNAL_EFFORT, EFFORT):
                if abs(eff) > lim.effort_max + lim.effort_tolerance:
                    eunit = "N" if j == 6 else "N m"
                    return Fault(
                        JOINT_LIMIT_EXCEEDED,
                        f"{name}: effort command {eff:.4g} {eunit} exceeds the limit "
                        f"{lim.effort_max:g} {eunit} (tolerance {lim.effort_tolerance:g})",
                    )
        return None

    def _too_fast(self, j: int, what: str, speed: float) -> Fault:
        lim, unit = self.limits[j], UNITS[j]
        return Fault(
            JOINT_LIMIT_EXCEEDED,
            f"{LABELS[j]}: {what} {speed:.4g} {unit}/s exceeds the velocity limit "
            f"{lim.velocity_max:.4g} {unit}/s (tolerance {lim.velocity_tolerance:.3g} {unit}/s)",
        )
