"""The arm controller's input checks: the joint limits a robot input must respect, and the
fault that puts the arm in its error state when it does not.

A real Trossen arm controller refuses robot inputs it must not follow: it enters an error
state, idles its joints and answers every request with that state until cleared. This module
is that rule, written once, for the served kit (``twin/``) and in-process evaluation
(:class:`~trossen_arm_mujoco.real.arm_controller.KitController`). :class:`InputChecker` (one
per arm) refuses a non-finite value (``ROBOT_INPUT_INFINITE``), a position outside the range
plus tolerance or a feedforward velocity beyond the limit plus tolerance
(``JOINT_LIMIT_EXCEEDED``), and in velocity / effort modes a command beyond its limit.
Limits (:func:`controller_limits`) are per driver value: 6 joints in rad, the gripper
carriage in m.

Docs: docs/real-kit.md; the limits and the order of checks: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from trossen_arm_mujoco.real.validate import POSITION_TOLERANCE, ArmLimits

__all__ = [
    "EFFORT",
    "EFFORT_LIMITS",
    "EFFORT_TOLERANCE_FRACTION",
    "EXTERNAL_EFFORT",
    "IDLE",
    "JOINT_LIMIT_EXCEEDED",
    "LABELS",
    "POSITION",
    "ROBOT_INPUT_INFINITE",
    "UNITS",
    "VELOCITY",
    "VELOCITY_TOLERANCE_FRACTION",
    "Fault",
    "InputChecker",
    "JointLimit",
    "controller_limits",
    "fault_from_message",
]

#: ``trossen_arm.Mode`` values of a joint (``trossen_arm_sim.protocol.Mode``).
IDLE, POSITION, VELOCITY, EXTERNAL_EFFORT, EFFORT = 0, 1, 2, 3, 4

#: Effort limits of the 7 driver values (URDF ``<limit effort>``): N m for joint_0..5, N for
#: the gripper carriage.
EFFORT_LIMITS: tuple[float, ...] = (27.0, 27.0, 27.0, 7.0, 7.0, 7.0, 400.0)

#: Velocity tolerance as a fraction of each velocity limit.
VELOCITY_TOLERANCE_FRACTION: float = 0.1

#: Effort tolerance as a fraction of each effort limit.
EFFORT_TOLERANCE_FRACTION: float = 0.05

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
    """A reason to enter the error state: the ``ErrorState`` value and one line, and what
    it was about: ``joint`` (a :data:`LABELS` entry, ``""`` when none), ``kind``
    (``non-finite``, ``position``, ``speed``, ``effort``, ``lag``), the value asked
    (``asked``: rad, rad/s, m, m/s, N m or N as the kind says) and the ``limit`` it broke
    (without its tolerance)."""

    state: int
    reason: str
    joint: str = ""
    kind: str = ""
    asked: float = math.nan
    limit: float = math.nan

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready fields (NaN as None)."""
        out = asdict(self)
        for key in ("asked", "limit"):
            if not math.isfinite(out[key]):
                out[key] = None
        return out


def controller_limits(arm: ArmLimits | None = None) -> list[JointLimit]:
    """The 7 joint limits of one arm's controller (see the module doc)."""
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
                    LABELS[j],
                    "non-finite",
                )
        for j, (mode, (pos, vel, eff)) in enumerate(zip(modes, values)):
            lim, unit, name = self.limits[j], UNITS[j], LABELS[j]
            vmax = lim.velocity_max + lim.velocity_tolerance
            if mode == POSITION:
                lo = lim.position_min - lim.position_tolerance
                hi = lim.position_max + lim.position_tolerance
                if not lo <= pos <= hi:
                    bound = lim.position_min if pos < lo else lim.position_max
                    return Fault(
                        JOINT_LIMIT_EXCEEDED,
                        f"{name}: position command {pos:.4g} {unit} is outside the joint "
                        f"limits [{lim.position_min:.4g}, {lim.position_max:.4g}] {unit} "
                        f"(tolerance {lim.position_tolerance:g} {unit})",
                        name,
                        "position",
                        float(pos),
                        float(bound),
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
                        name,
                        "effort",
                        float(abs(eff)),
                        float(lim.effort_max),
                    )
        return None

    def _too_fast(self, j: int, what: str, speed: float) -> Fault:
        lim, unit = self.limits[j], UNITS[j]
        return Fault(
            JOINT_LIMIT_EXCEEDED,
            f"{LABELS[j]}: {what} {speed:.4g} {unit}/s exceeds the velocity limit "
            f"{lim.velocity_max:.4g} {unit}/s (tolerance {lim.velocity_tolerance:.3g} {unit}/s)",
            LABELS[j],
            "speed",
            float(speed),
            float(lim.velocity_max),
        )


#: The reasons :class:`InputChecker` writes, as they reach a client in the controller's log.
_REASONS = (
    (
        re.compile(
            r"(joint_\d|gripper): (?:feedforward velocity|velocity command) ([-\d.e+]+) \S+ "
            r"exceeds the velocity limit ([-\d.e+]+)"
        ),
        "speed",
    ),
    (
        re.compile(
            r"(joint_\d|gripper): position command ([-\d.e+]+) \S+ is outside the joint "
            r"limits \[([-\d.e+]+), ([-\d.e+]+)\]"
        ),
        "position",
    ),
    (re.compile(r"(joint_\d|gripper): robot input with a non-finite value"), "non-finite"),
    (
        re.compile(
            r"(joint_\d|gripper): effort command ([-\d.e+]+) \S+ exceeds the limit "
            r"([-\d.e+]+)"
        ),
        "effort",
    ),
    (
        re.compile(r"(joint_\d|gripper): the target runs ([-\d.e+]+) \S+ ahead of the setpoint"),
        "lag",
    ),
)


def fault_from_message(message: str, side: str = "") -> dict[str, Any]:
    """The fields of a fault (``Fault.as_dict()`` without ``state``) read back from the
    error message a driver raised (the controller's log carries the reason the checks
    wrote); ``joint`` is ``<side>_<joint>`` when ``side`` is given. A message of another
    kind gives ``kind`` ``"other"`` and the message as its reason."""
    text = " ".join("".join(c for c in str(message) if c.isprintable() or c.isspace()).split())
    out: dict[str, Any] = {
        "reason": text,
        "joint": "",
        "kind": "other",
        "asked": None,
        "limit": None,
    }
    for pattern, kind in _REASONS:
        m = pattern.search(text)
        if not m:
            continue
        joint = m.group(1)
        out.update(joint=f"{side}_{joint}" if side else joint, kind=kind)
        numbers = [float(g) for g in m.groups()[1:]]
        if kind == "position":
            pos, lo, hi = numbers
            out.update(asked=pos, limit=lo if pos < lo else hi)
        elif kind in ("speed", "effort"):
            out.update(asked=numbers[0], limit=numbers[1])
        elif kind == "lag":
            out.update(asked=numbers[0])
        break
    return out
