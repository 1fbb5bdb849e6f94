"""The served kit's own faults: the joint-limit payload of the wire protocol, and one check
of the motion itself. The arm controller's input checks are ``real.controller_checks``
(shared with in-process evaluation).

A served arm enters the controller's error state as a real one does, until
``configure(..., clear_error=True)``. :func:`lag_fault`, run by the world every control
tick, faults a target running ahead of its rate-limited setpoint by more than
:data:`SETPOINT_LAG_S` of motion at the speed limit, measured in simulated time and only
while the world keeps real time.

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import astuple

import numpy as np

from trossen_arm_mujoco.real.controller_checks import (
    JOINT_LIMIT_EXCEEDED,
    LABELS,
    POSITION,
    UNITS,
    VELOCITY,
    Fault,
    JointLimit,
)

__all__ = ["SETPOINT_LAG_S", "lag_fault", "lag_fault_of", "pack_limits", "unpack_limits"]

#: How far a target may run ahead of the rate-limited setpoint, in seconds of motion at
#: the joint's speed limit (plus tolerance): 0.2 s is 0.75 rad for joint_0..2, 1.6 rad for
#: joint_3..5, 19 mm for the gripper. A client that stalls (a busy machine) and then sends
#: its trajectory's current point jumps too: 0.2 s keeps a stall of a few tenths of a
#: second at moderate speed from faulting the arm (0.15 s faulted a gripper move once on a
#: machine loaded 3x over its cores).
SETPOINT_LAG_S: float = 0.2

#: Byte layout of one joint limit on the wire: 7 little-endian floats.
_LIMIT_STRUCT = struct.Struct("<7f")


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
    """The fault of a target ``gap`` (rad, m) ahead of joint ``j``'s setpoint, or None.

    Args:
        j: the driver value's index (0-5 joints, 6 the gripper).
        gap: |target - setpoint| of that value (rad; gripper m).
        limit: its limits (``velocity_max``, ``velocity_tolerance``).
    """
    allowed = (limit.velocity_max + limit.velocity_tolerance) * SETPOINT_LAG_S
    if gap <= allowed:
        return None
    return Fault(
        JOINT_LIMIT_EXCEEDED,
        f"{LABELS[j]}: the target runs {gap:.4g} {UNITS[j]} ahead of the setpoint, more than "
        f"{SETPOINT_LAG_S:g} s at the velocity limit {limit.velocity_max:.4g} {UNITS[j]}/s "
        f"(a jump or a trajectory too fast for the joint)",
        LABELS[j],
        "lag",
        float(gap),
        float(allowed),
    )


def lag_fault_of(
    modes: np.ndarray, target: np.ndarray, setpoint: np.ndarray, limits: Sequence[JointLimit]
) -> Fault | None:
    """The first :func:`lag_fault` of an arm's joints in position or velocity mode.

    Args:
        modes: each driver value's ``trossen_arm.Mode``, (7,).
        target: the commanded targets, (7,) (rad; gripper m).
        setpoint: the rate-limited setpoints, (7,) (rad; gripper m).
        limits: each value's limits, 7 of them.
    """
    moving = (modes == POSITION) | (modes == VELOCITY)
    if not moving.any():
        return None
    gap = np.abs(target - setpoint)
    for j in np.flatnonzero(moving):
        fault = lag_fault(int(j), float(gap[j]), limits[j])
        if fault is not None:
            return fault
    return None
