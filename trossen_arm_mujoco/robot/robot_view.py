"""RobotView: a robot as a dict of named move groups over one MuJoCo model and its data.

``RobotView(data, move_groups)`` binds every group to ``data``; then ``get_qpos_dict()``,
``set_qpos_dict(qpos)``, ``get_ctrl_dict()``, ``get_noop_ctrl_dict()`` and
``get_jacobian(move_group_id, input_move_group_ids)`` read and write that state. The earlier
data-explicit form, ``RobotView(model, groups)`` with ``get_qpos_dict(data)``,
``set_qpos_dict(data, qpos)``, ``get_jacobian(data, frame_group, groups)`` ..., still works:
a call whose first argument is an ``MjData`` uses that data.

Docs: docs/reference/robot-sim.md, docs/concepts/architecture.md.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.base_group import RobotBaseGroup
from trossen_arm_mujoco.robot.binding import DataBound
from trossen_arm_mujoco.robot.checks import model_and_data
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin
from trossen_arm_mujoco.robot.move_group import MoveGroup

__all__ = ["RobotView"]


class RobotView(DataBound):
    """Named move groups of one robot; reads and writes qpos/ctrl by group name.

    Args:
        model: an ``MjData`` to bind every group to (the documented form), or the compiled
            model the groups were built on (then pass the data to each call, or ``bind``).
        move_groups: group id -> MoveGroup, in a fixed order.
    """

    def __init__(self, model: mujoco.MjData | mujoco.MjModel, move_groups: Mapping[str, MoveGroup]):
        self.model, data = model_and_data(model)
        self.move_groups: dict[str, MoveGroup] = dict(move_groups)
        self._data: mujoco.MjData | None = None
        if data is not None:
            self.bind(data)

    # -- binding (DataBound) -------------------------------------------------------------
    def _binding_name(self) -> str:
        return "robot view"

    def _binding_hint(self) -> str:
        return (
            "build it as RobotView(data, groups), call view.bind(data), or pass the data "
            "to the call"
        )

    def _bind_members(self, data: mujoco.MjData) -> None:
        for group in self.move_groups.values():
            group.bind(data)

    # -- groups --------------------------------------------------------------------------
    def move_group_ids(self) -> list[str]:
        """Ids of every move group, in order."""
        return list(self.move_groups)

    def get_move_group(self, mg_id: str) -> MoveGroup:
        """The move group ``mg_id`` (a UserError listing the valid ids when unknown)."""
        try:
            return self.move_groups[mg_id]
        except KeyError:
            raise unknown_name_error("move group", mg_id, self.move_groups) from None

    def base_group_ids(self) -> list[str]:
        """Ids of the base groups, in order (the first is the robot's primary base)."""
        return [n for n, g in self.move_groups.items() if isinstance(g, RobotBaseGroup)]

    @property
    def base(self) -> RobotBaseGroup:
        """The primary (first) base group."""
        ids = self.base_group_ids()
        if not ids:
            raise UserError(f"robot view has no base group (groups: {', '.join(self.move_groups)})")
        return self.move_groups[ids[0]]  # type: ignore[return-value]

    def _ids(self, ids: Iterable[str] | None, keep=None) -> list[str]:
        if ids is None:
            return [n for n, g in self.move_groups.items() if keep is None or keep(g)]
        if isinstance(ids, str):
            raise UserError(f"expected a list of move group ids, got the string '{ids}'")
        names = list(ids)
        for name in names:
            self.get_move_group(name)  # unknown ids fail here, listing the valid ones
        return names

    def _split(self, first) -> tuple[mujoco.MjData, Iterable[str] | None]:
        """(data, ids) of a call in either form: ``f(ids)`` or the earlier ``f(data)``."""
        if isinstance(first, mujoco.MjData):
            return first, None
        return self.data, first

    # -- state dicts ---------------------------------------------------------------------
    def get_qpos_dict(
        self, move_group_ids: Iterable[str] | mujoco.MjData | None = None
    ) -> dict[str, np.ndarray]:
        """Joint positions (rad / m) per group id: of ``move_group_ids``, default every
        group that has joints. (Earlier form: ``get_qpos_dict(data)``.)"""
        data, ids = self._split(move_group_ids)
        return {n: self.move_groups[n].get_qpos(data) for n in self._ids(ids, _has_joints)}

    def set_qpos_dict(self, qpos_dict, values: Mapping[str, np.ndarray] | None = None) -> None:
        """Write joint positions, group id -> (pos_dim,) array (run ``mj_kinematics`` /
        ``mj_forward`` afterwards). (Earlier form: ``set_qpos_dict(data, qpos_dict)``.)"""
        data, qpos = (
            (qpos_dict, values) if isinstance(qpos_dict, mujoco.MjData) else (None, qpos_dict)
        )
        data = self.data if data is None else data
        for name, q in (qpos or {}).items():
            self.get_move_group(name).set_qpos(data, q)

    def get_qvel_dict(
        self, move_group_ids: Iterable[str] | mujoco.MjData | None = None
    ) -> dict[str, np.ndarray]:
        """Joint velocities per group id, default every group that has joints."""
        data, ids = self._split(move_group_ids)
        return {n: self.move_groups[n].get_qvel(data) for n in self._ids(ids, _has_joints)}

    def get_ctrl_dict(
        self, move_group_ids: Iterable[str] | mujoco.MjData | None = None
    ) -> dict[str, np.ndarray]:
        """The control applied now per group id, default every controllable group."""
        data, ids = self._split(move_group_ids)
        return {n: self.move_groups[n].get_ctrl(data) for n in self._ids(ids, _has_ctrl)}

    def get_noop_ctrl_dict(
        self, move_group_ids: Iterable[str] | mujoco.MjData | None = None
    ) -> dict[str, np.ndarray]:
        """Controls that hold the current state per group id, default every controllable
        group: ``robot.update_control(view.get_noop_ctrl_dict())`` holds still."""
        data, ids = self._split(move_group_ids)
        return {n: self.move_groups[n].get_noop_ctrl(data) for n in self._ids(ids, _has_ctrl)}

    # -- Jacobians -----------------------------------------------------------------------
    def get_jacobian(self, move_group_id, input_move_group_ids=None, groups=None) -> np.ndarray:
        """Jacobian of a group's leaf frame w.r.t. the joints of the input groups.

        Args:
            move_group_id: group whose leaf frame moves (an arm: its tool frame).
            input_move_group_ids: groups whose dofs are the columns, in order (default all).

        Returns:
            (6, sum of the input groups' ``vel_dim``): rows [linear (m/unit); angular
            (rad/unit)] in the world frame. Valid after ``mj_forward`` (or ``mj_kinematics``
            + ``mj_comPos``) for the current qpos.

        Earlier form: ``get_jacobian(data, frame_group, groups=None)`` (frame groups with a
        tool frame only).
        """
        if isinstance(move_group_id, mujoco.MjData):
            data, frame_name, inputs = move_group_id, input_move_group_ids, groups
            frame = self.get_move_group(frame_name)
            if not isinstance(frame, MJCFFrameMixin):
                raise UserError(f"move group '{frame_name}' has no tool frame")
            jac = frame.get_frame_jacobian(self.model, data)
        else:
            inputs = input_move_group_ids
            jac = self.get_move_group(move_group_id).get_jacobian()
        return jac[:, self.dof_indices(inputs)]

    def dof_indices(self, groups: Iterable[str] | None = None) -> np.ndarray:
        """qvel indices of the dofs of ``groups`` (default all), concatenated in order."""
        idx = [self.move_groups[n].dof_idx for n in self._ids(groups)]
        return np.concatenate(idx) if idx else np.zeros(0, dtype=int)

    def qpos_indices(self, groups: Iterable[str] | None = None) -> np.ndarray:
        """qpos indices of the joints of ``groups`` (default all), concatenated in order."""
        idx = [self.move_groups[n].qpos_idx for n in self._ids(groups)]
        return np.concatenate(idx) if idx else np.zeros(0, dtype=int)


def _has_joints(group: MoveGroup) -> bool:
    return group.n_joints > 0


def _has_ctrl(group: MoveGroup) -> bool:
    return group.ctrl_dim > 0
