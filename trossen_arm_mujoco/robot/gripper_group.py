"""GripperGroup: two coupled fingers on one position actuator, opened and closed by name.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.checks import vector
from trossen_arm_mujoco.robot.limits import frozen
from trossen_arm_mujoco.robot.move_group import MoveGroup

__all__ = ["GripperGroup"]


class GripperGroup(MoveGroup):
    """Two coupled fingers driven by one position actuator.

    qpos has both finger joints (m, 0 closed to 0.044 open on the wxai); the control is one
    value: the target travel of the actuated finger (m). ``open_ctrl``/``closed_ctrl``
    (default the top / bottom of the actuator's range) are what ``set_gripper_ctrl_open``
    writes.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "left_gripper").
        joint_names: both finger joints.
        actuator_name: the position actuator of the actuated finger.
        open_ctrl: the open control (m); None: the top of the actuator's range.
        closed_ctrl: the closed control (m); None: the bottom of the actuator's range.
    """

    rate_limitable = True

    def __init__(
        self,
        model,
        name,
        joint_names,
        actuator_name: str,
        open_ctrl: float | None = None,
        closed_ctrl: float | None = None,
    ):
        super().__init__(model, name, joint_names)
        self.actuator_id = lookup_id(self.model, "actuator", actuator_name)
        self.actuator_ids = np.array([self.actuator_id], dtype=int)
        joint_of_actuator = int(self.model.actuator_trnid[self.actuator_id, 0])
        if joint_of_actuator not in self.joint_ids:
            raise UserError(f"{name}: actuator '{actuator_name}' drives none of {joint_names}")
        self.actuated_qpos_idx = int(self.model.jnt_qposadr[joint_of_actuator])
        self._ctrl_range = self.model.actuator_ctrlrange[self.actuator_id].copy()
        self._ctrl_low, self._ctrl_high = (
            frozen(self._ctrl_range[:1]),
            frozen(self._ctrl_range[1:]),
        )
        self.open_ctrl = float(self._ctrl_range[1] if open_ctrl is None else open_ctrl)
        self.closed_ctrl = float(self._ctrl_range[0] if closed_ctrl is None else closed_ctrl)

    @property
    def ctrl_dim(self) -> int:
        return 1

    def get_ctrl(self, data):
        return data.ctrl[[self.actuator_id]].copy()

    def set_ctrl(self, data, ctrl):
        c = vector(self.name, ctrl, 1)
        data.ctrl[self.actuator_id] = clip(c[0], *self._ctrl_range)

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self.actuator_id] = ctrl[0]

    def get_noop_ctrl(self, data):
        return self.noop_ctrl_view(data).copy()

    def noop_ctrl_view(self, data) -> np.ndarray:
        """``get_noop_ctrl`` as a live view of ``data.qpos`` (1,) m: it follows the
        simulation; read it, never write it."""
        i = self.actuated_qpos_idx
        return data.qpos[i : i + 1]

    def set_gripper_ctrl_open(self, open: bool) -> None:
        """Command the gripper fully open (``open_ctrl``) or closed (``closed_ctrl``)."""
        self.ctrl = [self.open_ctrl if open else self.closed_ctrl]

    @property
    def inter_finger_dist(self) -> float:
        """Opening between the fingers (m): the fingers' travel from closed summed
        (q - lower limit per finger joint); on the wxai about the pad gap (pads touch at 0)."""
        q = self.joint_pos
        return float(np.sum(q - self.joint_range[:, 0]))

    @property
    def inter_finger_dist_range(self) -> tuple[float, float]:
        """(closed, fully open) values of ``inter_finger_dist`` (m)."""
        return 0.0, float(np.sum(self.joint_range[:, 1] - self.joint_range[:, 0]))

    @property
    def is_open(self) -> bool:
        """Whether the fingers are more than half open."""
        low, high = self.inter_finger_dist_range
        return self.inter_finger_dist > 0.5 * (low + high)
