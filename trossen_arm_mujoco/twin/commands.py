"""What the clients of one served arm command now: per driver value a mode and a target.

The arm adapter (:mod:`.arm_adapter`) writes an :class:`ArmState` from the robot inputs;
the world (:mod:`.kit_world`) reads it every control tick. Driver values: ``joint_0`` ..
``joint_5`` (rad) and the gripper carriage (m).

Docs: docs/cli/serve.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

# ``trossen_arm_sim.protocol.Mode`` values, defined with the controller's checks
from trossen_arm_mujoco.real.controller_checks import (
    IDLE,
)

__all__ = ["ArmState"]


class ArmState:
    """What the clients of one arm command now: per driver value a mode, a position target
    (rad / m) and, in the effort modes, a generalized force (N m / N); and the joint limits
    (``faults.JointLimit``, 7) the world checks the motion against (None: unchecked)."""

    def __init__(self, start: np.ndarray, limits: Sequence[Any] | None = None) -> None:
        self.modes = np.full(7, IDLE, dtype=np.int64)
        self.target = np.asarray(start, dtype=np.float64).copy()
        self.effort = np.zeros(7)
        self.limits = None if limits is None else list(limits)
