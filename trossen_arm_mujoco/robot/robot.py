"""Robot: a robot view with one controller per move group."""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.controllers import Controller, make_controller
from trossen_arm_mujoco.robot.move_group import MocapArmGroup
from trossen_arm_mujoco.robot.robot_view import RobotView


class Robot:
    """Commands in, controls out.

    ``update_control`` stores the latest command per move group; ``compute_control`` turns
    the stored commands into controls and writes them to ``data.ctrl`` (or the mocap bodies).
    Groups without a command hold the control set at ``reset``. Physics is never stepped here.

    Joint-actuated groups are rate-limited (``MoveGroupSpec.velocity_limits``): each call
    of ``compute_control`` moves their control by at most ``velocity_limits * ctrl_dt``.
    A relative command (``joint_rel_position``, ``ee_delta``) is taken against the joints
    once, when first applied; its joint target is then approached over as many ticks as
    the limits need, unless a newer command replaces it.

    Args:
        model: compiled model.
        config: move groups, initial joints, command modes, velocity limits.
        ctrl_dt: control period (s), the time between two ``compute_control`` calls;
            default the model timestep. Controllers put into ``controllers`` later without
            a ``ctrl_dt`` of their own take this one.
    """

    def __init__(self, model: mujoco.MjModel, config: RobotConfig, ctrl_dt: float | None = None):
        self.model = model
        self.config = config
        self.ctrl_dt = float(model.opt.timestep) if ctrl_dt is None else float(ctrl_dt)
        if not (np.isfinite(self.ctrl_dt) and self.ctrl_dt > 0):
            raise UserError(f"ctrl_dt must be a positive number of seconds, got {ctrl_dt}")
        self.view: RobotView = config.build_view(model)
        self.controllers: dict[str, Controller] = {
            g: make_controller(mode, self.view.group(g), model, self.ctrl_dt)
            for g, mode in config.command_mode.items()
        }
        self._commands: dict[str, np.ndarray] = {}
        # resolved relative commands not yet reached: (target, target within ctrl limits)
        self._targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def update_control(self, commands: Mapping[str, np.ndarray]) -> None:
        """Store commands, group name -> vector of that group's ``command_dim`` values."""
        for name, cmd in commands.items():
            if name not in self.controllers:
                raise unknown_name_error("controlled move group", name, self.controllers)
            self._commands[name] = self.controllers[name]._check(cmd)

    def compute_control(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Compute and apply the controls of the commanded groups; returns them by group."""
        out = {}
        controllers = self.controllers
        if self._commands:
            for name, cmd in list(self._commands.items()):
                controller = controllers[name]
                if controller.ctrl_dt is None:
                    controller.ctrl_dt = self.ctrl_dt
                target = controller._target(data, cmd)  # cmd was checked by update_control
                if controller.relative:  # applied once: its target holds until reached
                    group = controller.group
                    reached = np.minimum(np.maximum(target, group._ctrl_low), group._ctrl_high)
                    self._targets[name] = (target, reached)
                    del self._commands[name]
                else:
                    out[name] = controller.limit(data, target)
        if self._targets:
            for name, (target, reached) in list(self._targets.items()):
                ctrl = out[name] = controllers[name].limit(data, target)
                if (ctrl == reached).all():
                    del self._targets[name]  # reached: the control now holds it
        for name, ctrl in out.items():
            controllers[name].group._write_ctrl(data, ctrl)
        return out

    def reset(self, data: mujoco.MjData) -> None:
        """Put the joints at ``config.init_qpos`` at rest, and every control at a no-op.

        Mocap arms get their mocap pose set to the tool-frame pose of the initial joints,
        so the weld holds the arm where it is.
        """
        self.view.set_qpos_dict(data, self.config.init_qpos)
        for name in self.config.init_qpos:
            data.qvel[self.view.group(name).dof_idx] = 0.0
        self._commands.clear()
        self._targets.clear()
        mujoco.mj_kinematics(self.model, data)
        self.hold(data)

    def hold(self, data: mujoco.MjData) -> None:
        """Set every control to hold the current state (kinematics must be up to date)."""
        self._commands.clear()
        self._targets.clear()
        for group in self.view.move_groups.values():
            if isinstance(group, MocapArmGroup):
                group.set_ctrl(data, group.get_frame_pose(data))
            elif group.ctrl_dim:
                group.set_ctrl(data, group.get_noop_ctrl(data))
