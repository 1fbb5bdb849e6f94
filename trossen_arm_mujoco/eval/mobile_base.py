"""The Mobile AI's base in eval's kit env (``eval.env.KitPolicyEnv``, layout ``mobileai``).

A Mobile AI task is observed and acted on in the ``mobileai`` layout, as Trossen's
``mobileai_robot`` reads and commands the real robot: the arms' 14 values, then the base's
``x.vel`` (m/s) and ``theta.vel`` (rad/s). Base commands are clipped to the real base's
limits (+-1.0 m/s, +-1.0 rad/s) and counted, never a fault; a non-finite one is a fault with
the checks on and a ``UserError`` with them off.

Docs: docs/cli/eval.md, docs/concepts/models.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import mobile_ai_config
from trossen_arm_mujoco.robot.layout import BASE_VALUES, MOBILEAI_LAYOUT
from trossen_arm_mujoco.tasks import registry

__all__ = ["MOBILE_LAYOUTS", "MobileBase", "mobile_names"]

#: The layouts a Mobile AI policy may use.
MOBILE_LAYOUTS = ("mobileai",)
#: The robot a Mobile AI task's sampler drives.
MOBILE_ROBOT = mobile_ai_config().name


def mobile_names() -> list[str]:
    """Tasks of the Mobile AI: the ones eval's kit env takes in the ``mobileai`` layout."""
    return [
        n
        for n in registry.names()
        if getattr(registry.load(n).sampler_class(), "robot_name", "") == MOBILE_ROBOT
    ]


class MobileBase:
    """The base part of a ``mobileai`` env: the base's controller looked up once, its command
    limits, what a step's base command did.

    Args:
        robot: the task's robot (its ``base_velocity`` controller drives the base).
        checks: the controller checks are on (a non-finite command is a fault, not an error).
    """

    def __init__(self, robot: Any, checks: bool):
        names = [n for n, c in robot.controllers.items() if c.command_mode == "base_velocity"]
        if len(names) != 1:
            raise UserError(f"a mobileai env needs one velocity-driven base, found {names}")
        self.name = names[0]
        self.controller = robot.controllers[self.name]
        self.group = self.controller.group
        self.low, self.high = self.controller.command_limits()
        self.checks = bool(checks)
        self._clipped_at_reset = 0

    def reset(self) -> None:
        """Start counting the clipped commands of a new episode."""
        self._clipped_at_reset = self.controller.clipped_commands

    @property
    def clipped(self) -> int:
        """Base commands of this episode that the controller clipped to the limits."""
        return self.controller.clipped_commands - self._clipped_at_reset

    def command(self, action: np.ndarray, step: int) -> tuple[dict[str, np.ndarray], dict | None]:
        """({base group: its [x.vel, theta.vel]}, fault or None) of a (16,) action; a
        non-finite value is a fault (checks on) or a UserError (checks off)."""
        values = np.asarray(action, dtype=float)[MOBILEAI_LAYOUT.base]
        if np.isfinite(values).all():
            return {self.name: values}, None
        bad = int(np.flatnonzero(~np.isfinite(values))[0])
        if not self.checks:
            raise UserError(f"action's base {BASE_VALUES[bad]} is {values[bad]}: not a number")
        reason = f"base {BASE_VALUES[bad]} command {values[bad]} is not a finite number"
        fault = {
            "state": None,
            "reason": reason,
            "joint": BASE_VALUES[bad],
            "kind": "non-finite",
            "asked": None,
            "limit": None,
            "step": step,
        }
        return {}, fault

    def measured(self, data: Any) -> np.ndarray:
        """(2,) the base's measured [x.vel m/s, theta.vel rad/s]."""
        return self.group.get_base_velocity(data)

    def action_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(2,) low and high of the base's action values: the real base's limits."""
        return self.low.astype(float), self.high.astype(float)

    @staticmethod
    def observation_bounds(bounds: dict[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        """(2, 2) [[low x.vel, low theta.vel], [high ...]] of the measured velocities, from
        the task's ``base_vel`` bounds (linear x, angular z)."""
        low, high = bounds["base_vel"]
        return np.array([[low[0], low[5]], [high[0], high[5]]], dtype=float)
