"""JointTargetBatch: the absolute joint-position commands of several move groups of one
robot, rate-limited and written as one vector per control tick.

``Robot.compute_control`` runs every controller once per tick; for the common case, where
the commanded groups are plain ``joint_position`` groups (an arm and its gripper, or both
arms and grippers of the kit), the per-group work is the same few vector operations on a few
values each. A batch does them once over all those groups' actuators: the same arithmetic
as ``Controller.limit`` value by value, so the controls are identical, with one pass instead
of one per group.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.robot.controllers import Controller, JointPosController
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.move_group import SimplyActuatedMoveGroup
from trossen_arm_mujoco.robot.selection import as_slice

_PLAIN_GROUPS = (SimplyActuatedMoveGroup, GripperGroup)


def batchable(controller: Controller) -> bool:
    """Whether a controller's tick is exactly "clip the step toward the command to
    ``max_step``, clip to the control range, write ``data.ctrl`` at the actuators": a
    ``JointPosController`` (not a subclass) with velocity limits, on an arm or gripper group
    whose control reads and writes are the package's own."""
    if type(controller) is not JointPosController or controller._steps()[0] is None:
        return False
    kind = type(controller.group)
    return any(
        kind.get_ctrl is base.get_ctrl and kind._write_ctrl is base._write_ctrl
        for base in _PLAIN_GROUPS
    )


class JointTargetBatch:
    """The commands of ``batchable`` controllers, as one target vector over their actuators.

    Args:
        controllers: group id -> controller (each ``batchable``, ``ctrl_dt`` set).
        names: the group ids batched, in command order.

    The actuators, velocity limits and control ranges are gathered once, here; ``fits``
    says whether they still hold (``Robot`` builds a new batch when not). ``set_target``
    takes each new set of commands.
    """

    def __init__(self, controllers: Mapping[str, Controller], names: Sequence[str]):
        self.names: tuple[str, ...] = tuple(names)
        # the controllers and their cached step arrays (new objects whenever the velocity
        # limits or ctrl_dt change), kept to be compared by identity
        self._sources = [(controllers[n], controllers[n]._steps()[0]) for n in self.names]
        groups = [controllers[n].group for n in self.names]
        self._sel = as_slice(np.concatenate([g.actuator_ids for g in groups]))
        self._step = np.concatenate([step for _, step in self._sources])
        self._neg_step = -self._step
        self._low = np.concatenate([g._ctrl_low for g in groups])
        self._high = np.concatenate([g._ctrl_high for g in groups])
        self._target = np.zeros(len(self._step))
        bounds = np.cumsum([0] + [len(g.actuator_ids) for g in groups])
        self._slices = [
            (n, slice(int(a), int(b))) for n, a, b in zip(self.names, bounds, bounds[1:])
        ]

    def fits(self, controllers: Mapping[str, Controller]) -> bool:
        """Whether ``controllers`` still hold the same controllers, with the same limits and
        ``ctrl_dt``, as when the batch was built."""
        return all(
            controllers.get(n) is c and c._steps()[0] is step
            for n, (c, step) in zip(self.names, self._sources)
        )

    def set_target(self, commands: Mapping[str, np.ndarray]) -> None:
        """Take the checked commands (group id -> (ctrl_dim,) rad or m) of ``names``."""
        self._target = np.concatenate([commands[n] for n in self.names])

    def apply(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Move every control toward its target by at most ``max_step``, clip it to the
        control range, write it to ``data.ctrl``; returns the controls by group id."""
        current = data.ctrl[self._sel]
        u = self._target - current
        np.minimum(np.maximum(u, self._neg_step, out=u), self._step, out=u)
        u += current
        np.minimum(np.maximum(u, self._low, out=u), self._high, out=u)
        data.ctrl[self._sel] = u
        return {name: u[s] for name, s in self._slices}


def split_batchable(
    controllers: Mapping[str, Controller], names: Sequence[str]
) -> tuple[tuple[str, ...], list[str]]:
    """(ids whose controllers are ``batchable``, the others), in the order of ``names``."""
    plain, other = [], []
    for name in names:
        (plain if batchable(controllers[name]) else other).append(name)
    return tuple(plain), other
