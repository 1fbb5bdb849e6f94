"""Gripper commands above the arm controller's range: clamped before sending, and counted.

The MJCF carriage joint, and so the recorded data, travels 0 .. 0.044 m (one finger's
travel from closed), but the arm controller accepts at most :data:`GRIPPER_MAX` (0.04 m)
and would clip larger commands silently. Replay therefore clamps every gripper command to
``--gripper_max`` (default :data:`GRIPPER_MAX`) itself, and reports how many it clamped
(console and JSON summary), so that the difference is never silent. The simulated twin
gets the same clamped commands as the real arms.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["GRIPPER_INDEX", "GRIPPER_MAX", "GripperClamp", "clamp_gripper"]

#: Largest gripper command the arm controller accepts (m, one carriage's travel).
GRIPPER_MAX: float = 0.04

#: Index of the gripper among the 7 values sent to one arm.
GRIPPER_INDEX: int = 6


@dataclass
class GripperClamp:
    """Gripper commands of a trajectory clamped to ``gripper_max``.

    Attributes:
        gripper_max: the limit (m).
        total: gripper commands in the trajectory (steps x 2 arms).
        count: commands above ``gripper_max``, clamped to it.
        per_arm: ``{"left": n, "right": n}``, the same count per arm.
        max_excess: largest amount a command was above the limit (m; 0 when none).
    """

    gripper_max: float
    total: int
    count: int
    per_arm: dict[str, int] = field(default_factory=dict)
    max_excess: float = 0.0

    def describe(self) -> str:
        """One line for the console."""
        head = f"gripper commands above --gripper_max {self.gripper_max:g} m"
        if not self.count:
            return f"{head}: none (0 of {self.total} clamped)"
        arms = ", ".join(f"{arm} {n}" for arm, n in self.per_arm.items())
        return (
            f"{head}: {self.count} of {self.total} clamped to it ({arms}; largest excess "
            f"{self.max_excess * 1000:.2f} mm)"
        )

    def as_dict(self) -> dict[str, Any]:
        """Fields of the JSON summary."""
        return {
            "gripper_max_m": self.gripper_max,
            "gripper_commands": self.total,
            "gripper_clamped": self.count,
            "gripper_clamped_per_arm": dict(self.per_arm),
            "gripper_max_excess_m": self.max_excess,
        }


def clamp_gripper(
    commands: np.ndarray, gripper_max: float = GRIPPER_MAX, arms: Sequence[str] = ("left", "right")
) -> tuple[np.ndarray, GripperClamp]:
    """Clamp the gripper values of ``commands`` to at most ``gripper_max``.

    Args:
        commands: ``(T, 2, 7)`` driver values per step and arm (rad; gripper m).
        gripper_max: the largest gripper value (m).
        arms: the arms' names, in the order of axis 1 (for the count).

    Returns:
        ``(clamped copy, GripperClamp)``; ``commands`` itself is not modified.
    """
    out = np.array(commands, dtype=np.float64, copy=True)
    grip = out[..., GRIPPER_INDEX]  # (T, 2)
    above = grip > gripper_max
    excess = float((grip[above] - gripper_max).max()) if above.any() else 0.0
    per_arm = {arm: int(above[:, a].sum()) for a, arm in enumerate(arms)}
    out[..., GRIPPER_INDEX] = np.minimum(grip, gripper_max)
    clamp = GripperClamp(float(gripper_max), int(grip.size), int(above.sum()), per_arm, excess)
    return out, clamp
