"""JointTargetBatch: the absolute joint-position commands of several move groups of one
robot, rate-limited and written as one vector per control tick.

When the commanded groups are plain ``joint_position`` groups (an arm and its gripper, or
the kit's arms and grippers), a batch does ``Controller.limit``'s arithmetic once over all
their actuators: the controls are identical, in one pass. A caller holding all the commands
as one vector hands them over as ``JointTargets`` (``batch.commands``: views of that vector,
checked once). ``preview`` says where the controls will be after some ticks without writing
them; with ``keep=True`` the next tick reuses that result.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.arm_groups import SimplyActuatedMoveGroup
from trossen_arm_mujoco.robot.controllers import Controller, JointPosController
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["JointTargetBatch", "JointTargets", "batchable", "split_batchable"]

_PLAIN_GROUPS = (SimplyActuatedMoveGroup, GripperGroup)


def batchable(controller: Controller) -> bool:
    """Whether a controller's tick is exactly "clip the step toward the command to
    ``max_step``, clip to the control range, write ``data.ctrl`` at the actuators": a
    ``JointPosController`` (not a subclass) with velocity limits and a ``ctrl_dt``, on an arm
    or gripper group whose control reads and writes are the package's own."""
    if (
        type(controller) is not JointPosController
        or controller.ctrl_dt is None
        or controller._steps()[0] is None
    ):
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
        # the controllers, their velocity limits (compared by identity: set_velocity_limits
        # makes a new array) and ctrl_dt, as the batch was built from them
        self._sources = [
            (controllers[n], controllers[n].group.velocity_limits, controllers[n].ctrl_dt)
            for n in self.names
        ]
        groups = [controllers[n].group for n in self.names]
        self._sel = as_slice(np.concatenate([g.actuator_ids for g in groups]))
        self._step = np.concatenate([controllers[n]._steps()[0] for n in self.names])
        self._neg_step = -self._step
        self._low = np.concatenate([g._ctrl_low for g in groups])
        self._high = np.concatenate([g._ctrl_high for g in groups])
        #: number of values of the target vector (the groups' actuators, in ``names`` order)
        self.size = len(self._step)
        self._target = np.zeros(self.size)
        # (data, data.time, target, controls) of the last preview kept for the next tick
        self._kept: tuple | None = None
        bounds = np.cumsum([0] + [len(g.actuator_ids) for g in groups])
        self._slices = [
            (n, slice(int(a), int(b))) for n, a, b in zip(self.names, bounds, bounds[1:])
        ]

    def fits(self, controllers: Mapping[str, Controller]) -> bool:
        """Whether ``controllers`` still hold the same controllers, with the same limits and
        ``ctrl_dt``, as when the batch was built."""
        for name, (controller, limits, dt) in zip(self.names, self._sources):
            if (
                controllers.get(name) is not controller
                or controller.group.velocity_limits is not limits
                or controller.ctrl_dt != dt
            ):
                return False
        return True

    def set_target(self, commands: Mapping[str, np.ndarray]) -> None:
        """Take the checked commands (group id -> (ctrl_dim,) rad or m) of ``names``."""
        self._target = np.concatenate([commands[n] for n in self.names])

    def set_vector(self, vector: np.ndarray) -> None:
        """Take the targets as one checked vector, (size,) in ``names`` order."""
        self._target = vector

    def commands(self, vector: np.ndarray) -> JointTargets:
        """The commands of ``names`` as one vector, ``(size,)`` rad or m in ``names`` order,
        checked here once (a one-line UserError on a wrong size or a NaN/inf); see
        ``JointTargets``."""
        v = np.asarray(vector, dtype=float).reshape(-1)
        if v.shape[0] != self.size:
            raise UserError(
                f"joint targets of {', '.join(self.names)}: expected {self.size} values, "
                f"got {v.size}"
            )
        if not math.isfinite(v.dot(v)) and not np.isfinite(v).all():  # v.v may overflow
            raise UserError(f"joint targets of {', '.join(self.names)} contain NaN or inf")
        return JointTargets(self, v)

    def _limited(self, data: mujoco.MjData, target: np.ndarray, ticks: int) -> np.ndarray:
        """The controls after ``ticks`` ticks toward ``target`` (a new array)."""
        current = data.ctrl[self._sel]
        step, neg_step = self._step, self._neg_step
        if ticks != 1:
            step, neg_step = step * ticks, neg_step * ticks
        u = target - current
        clip(u, neg_step, step, out=u)
        u += current
        return clip(u, self._low, self._high, out=u)

    def preview(
        self, data: mujoco.MjData, target: np.ndarray, ticks: int = 1, keep: bool = False
    ) -> np.ndarray:
        """Where the controls will be after ``ticks`` ticks toward ``target`` ((size,), rad or
        m), from ``data.ctrl``; nothing is written. Value by value what ``ticks`` calls of
        ``apply`` would leave (``Controller.limit`` with ``ticks``).

        Args:
            data: the state; the start is ``data.ctrl``.
            target: (size,) joint targets (rad or m).
            ticks: the number of control ticks.
            keep: (one tick) the caller hands this very ``target`` array over, unchanged, as
                the batch's target (``set_vector``, e.g. through ``JointTargets``) before the
                next tick; that tick then writes the result kept here instead of computing
                it again, as long as ``data`` is where it was (same ``data.time``: no physics
                step in between).

        Returns:
            (size,) the controls after ``ticks`` ticks.
        """
        u = self._limited(data, target, ticks)
        if keep and ticks == 1:
            self._kept = (data, data.time, target, u)
        return u

    def apply(self, data: mujoco.MjData) -> np.ndarray:
        """Move every control toward its target by at most ``max_step``, clip it to the
        control range, write it to ``data.ctrl``; returns the controls (size,) (``by_group``
        splits them)."""
        kept, self._kept = self._kept, None
        if (
            kept is not None
            and kept[2] is self._target
            and kept[0] is data
            and kept[1] == data.time
        ):
            u = kept[3]  # the kept preview of this very tick
        else:
            u = self._limited(data, self._target, 1)
        data.ctrl[self._sel] = u
        return u

    def by_group(self, values: np.ndarray) -> dict[str, np.ndarray]:
        """(size,) values in ``names`` order -> group id -> that group's values (views)."""
        return {name: values[s] for name, s in self._slices}


class JointTargets(dict):
    """Commands of a batch's groups as views of one checked vector (``batch.commands``):
    group id -> (ctrl_dim,) rad or m. A plain dict to everyone else; ``Robot.update_control``
    takes ``vector`` as the batch's target directly when the batch is still its own.

    Attributes:
        batch: the ``JointTargetBatch`` the vector is laid out for.
        vector: (batch.size,) the targets, in ``batch.names`` order.
    """

    __slots__ = ("batch", "vector")

    def __init__(self, batch: JointTargetBatch, vector: np.ndarray):
        put = dict.__setitem__  # filling it is no change: the vector stays
        for name, s in batch._slices:
            put(self, name, vector[s])
        self.batch: JointTargetBatch = batch
        self.vector: np.ndarray | None = vector


def _forgets_vector(name: str):
    """A dict method that, on a JointTargets, first drops ``vector`` (the entries may no
    longer be its views; the robot then reads the entries one by one)."""
    method = getattr(dict, name)

    def wrapper(self, *args, **kwargs):
        self.vector = None
        return method(self, *args, **kwargs)

    wrapper.__name__ = name
    wrapper.__qualname__ = f"JointTargets.{name}"
    wrapper.__doc__ = (
        f"``dict.{name}``, after dropping ``vector``: the entries may no longer be its views "
        "(the robot then reads them one by one)."
    )
    return wrapper


for _name in (
    "__setitem__",
    "__delitem__",
    "__ior__",
    "update",
    "pop",
    "popitem",
    "setdefault",
    "clear",
):
    setattr(JointTargets, _name, _forgets_vector(_name))


def split_batchable(
    controllers: Mapping[str, Controller], names: Sequence[str]
) -> tuple[tuple[str, ...], list[str]]:
    """(ids whose controllers are ``batchable``, the others), in the order of ``names``."""
    plain, other = [], []
    for name in names:
        (plain if batchable(controllers[name]) else other).append(name)
    return tuple(plain), other
