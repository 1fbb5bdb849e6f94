"""Arm move groups, by how they are commanded.

- ``SimplyActuatedMoveGroup``: one position actuator per joint; the control is the joint
  targets (rad / m), clipped to the actuators' ``ctrlrange`` when written.
- ``ArmMoveGroup``: such a group with a tool frame (``mjcf_frame.MJCFFrameMixin``).
- ``MocapArmGroup``: an arm pulled by a mocap body welded to its last link; the control is the
  mocap pose [x, y, z, qw, qx, qy, qz] (world frame, m), its quaternion normalized.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.checks import vector
from trossen_arm_mujoco.robot.joint_indices import actuator_ids
from trossen_arm_mujoco.robot.limits import frozen
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["ArmMoveGroup", "MocapArmGroup", "SimplyActuatedMoveGroup"]


class SimplyActuatedMoveGroup(MoveGroup):
    """One position actuator per joint: the control is the joint target (rad or m).

    ``joint_ids``, ``actuator_ids``, ``joint_posadr``, ``joint_veladr``: model indices.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "left_arm").
        joint_names: the group's joints, in command order.
        actuator_names: one position actuator per joint, in the same order.

    Raises:
        UserError: not one actuator per joint, or a name the model lacks.
    """

    rate_limitable = True

    def __init__(self, model, name, joint_names, actuator_names: Sequence[str]):
        super().__init__(model, name, joint_names)
        if len(actuator_names) != len(joint_names):
            raise UserError(f"{name}: one actuator per joint is required")
        self.actuator_ids = actuator_ids(self.model, actuator_names)
        self._ctrl_range = self.model.actuator_ctrlrange[self.actuator_ids].copy()
        self._ctrl_low, self._ctrl_high = (
            frozen(self._ctrl_range[:, 0]),
            frozen(self._ctrl_range[:, 1]),
        )
        self._ctrl_sel = as_slice(self.actuator_ids)

    @property
    def ctrl_dim(self) -> int:
        return len(self.actuator_ids)

    def get_ctrl(self, data):
        return data.ctrl[self._ctrl_sel].copy()

    def set_ctrl(self, data, ctrl):
        c = vector(self.name, ctrl, self.ctrl_dim)
        data.ctrl[self.actuator_ids] = clip(c, self._ctrl_low, self._ctrl_high)

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self._ctrl_sel] = ctrl

    def get_noop_ctrl(self, data):
        return self.get_qpos(data)


class ArmMoveGroup(MJCFFrameMixin, SimplyActuatedMoveGroup):
    """A joint-actuated arm with a tool frame (a site, or a body with ``frame_type="body"``).

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "left_arm").
        joint_names: the arm's joints, in command order.
        actuator_names: one position actuator per joint, in the same order.
        frame_site: the tool frame's name (a site, or a body).
        frame_type: ``"site"`` or ``"body"``.
    """

    def __init__(
        self, model, name, joint_names, actuator_names, frame_site: str, frame_type: str = "site"
    ):
        super().__init__(model, name, joint_names, actuator_names)
        self._init_frame(self.model, frame_site, frame_type)


class MocapArmGroup(MJCFFrameMixin, MoveGroup):
    """An arm driven by a mocap body welded to its last link.

    The control is the mocap pose [x, y, z, qw, qx, qy, qz] (world frame, m); the weld pulls
    the arm's tool frame onto it. qpos/qvel are the arm's joints.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name.
        joint_names: the arm's joints.
        mocap_body: the mocap body welded to the arm.
        frame_site: the tool frame's site.

    Raises:
        UserError: ``mocap_body`` is not a mocap body, or a name the model lacks.
    """

    def __init__(self, model, name, joint_names, mocap_body: str, frame_site: str):
        super().__init__(model, name, joint_names)
        body_id = lookup_id(self.model, "body", mocap_body)
        self.mocap_id = int(self.model.body_mocapid[body_id])
        if self.mocap_id < 0:
            raise UserError(f"{name}: body '{mocap_body}' is not a mocap body")
        self._init_frame(self.model, frame_site)
        self._ctrl_low = frozen(np.array([-2.0, -2.0, -2.0, -1, -1, -1, -1]))
        self._ctrl_high = frozen(np.array([2.0, 2.0, 2.0, 1, 1, 1, 1]))

    @property
    def ctrl_dim(self) -> int:
        return 7

    def get_ctrl(self, data):
        return np.concatenate([data.mocap_pos[self.mocap_id], data.mocap_quat[self.mocap_id]])

    def set_ctrl(self, data, ctrl):
        c = vector(self.name, ctrl, 7)
        norm = np.linalg.norm(c[3:])
        if norm < 1e-9:
            raise UserError(f"{self.name}: mocap quaternion has zero length")
        data.mocap_pos[self.mocap_id] = c[:3]
        data.mocap_quat[self.mocap_id] = c[3:] / norm

    def get_noop_ctrl(self, data):
        return self.get_ctrl(data)
