"""RobotView: a robot as a dict of named move groups over one MuJoCo model."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.move_group import MJCFFrameMixin, MoveGroup


class RobotView:
    """Named move groups of one robot; reads and writes qpos/ctrl by group name.

    Args:
        model: compiled model the groups were built on.
        move_groups: group name -> MoveGroup, in a fixed order.
    """

    def __init__(self, model: mujoco.MjModel, move_groups: Mapping[str, MoveGroup]):
        self.model = model
        self.move_groups: dict[str, MoveGroup] = dict(move_groups)

    def group(self, name: str) -> MoveGroup:
        try:
            return self.move_groups[name]
        except KeyError:
            raise unknown_name_error("move group", name, self.move_groups) from None

    def _names(self, names: Iterable[str] | None) -> list[str]:
        return list(self.move_groups) if names is None else [self.group(n).name for n in names]

    def get_qpos_dict(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Joint positions per group (rad / m); groups without joints are omitted."""
        return {n: g.get_qpos(data) for n, g in self.move_groups.items() if g.n_joints}

    def set_qpos_dict(self, data: mujoco.MjData, qpos: Mapping[str, np.ndarray]) -> None:
        """Write joint positions of the named groups (call mj_forward afterwards)."""
        for name, q in qpos.items():
            self.group(name).set_qpos(data, q)

    def get_qvel_dict(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        return {n: g.get_qvel(data) for n, g in self.move_groups.items() if g.n_joints}

    def get_ctrl_dict(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """The control currently applied per controllable group."""
        return {n: g.get_ctrl(data) for n, g in self.move_groups.items() if g.ctrl_dim}

    def get_noop_ctrl_dict(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Controls that hold the current state, per controllable group."""
        return {n: g.get_noop_ctrl(data) for n, g in self.move_groups.items() if g.ctrl_dim}

    def get_jacobian(
        self, data: mujoco.MjData, frame_group: str, groups: Iterable[str] | None = None
    ) -> np.ndarray:
        """Jacobian of ``frame_group``'s tool frame, masked to the dofs of ``groups``.

        Returns:
            (6, k) array, rows [linear (m/unit); angular (rad/unit)] in the world frame,
            columns the dofs of ``groups`` (default: all groups) in group order.
        """
        frame = self.group(frame_group)
        if not isinstance(frame, MJCFFrameMixin):
            raise UserError(f"move group '{frame_group}' has no tool frame")
        jac = frame.get_frame_jacobian(self.model, data)
        cols = self.dof_indices(groups)
        return jac[:, cols]

    def dof_indices(self, groups: Iterable[str] | None = None) -> np.ndarray:
        """qvel indices of the dofs of ``groups`` (default all), concatenated in order."""
        idx = [self.group(n).dof_idx for n in self._names(groups)]
        return np.concatenate(idx) if idx else np.zeros(0, dtype=int)

    def qpos_indices(self, groups: Iterable[str] | None = None) -> np.ndarray:
        idx = [self.group(n).qpos_idx for n in self._names(groups)]
        return np.concatenate(idx) if idx else np.zeros(0, dtype=int)
