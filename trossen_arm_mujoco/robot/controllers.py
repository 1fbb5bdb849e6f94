"""Controllers turn a move group's command into its control. They never step physics.

Command modes: ``joint_position`` (absolute joint targets, rad / m), ``joint_rel_position``
(deltas added to the current joints), ``ee_pose`` (tool-frame pose [x, y, z, qw, qx, qy, qz],
world frame, m; mocap arms take it as is, joint arms by IK), ``ee_delta`` (tool-frame delta
[dx, dy, dz] m, or 6 values with a rotation vector in rad, world frame, differential IK) and
``base_velocity`` ([x.vel m/s, theta.vel rad/s] of a differential-drive base). A controller
keeps no state: each tick ``limit`` moves the control applied in ``data`` toward the target
by at most ``velocity_limits * ctrl_dt`` per value, then clips it to the control range
(mocap arms are not rate-limited). A robot's safety floor is held as ``floor``.

Docs: docs/concepts/architecture.md (the robot layer); details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.arm_groups import MocapArmGroup, SimplyActuatedMoveGroup
from trossen_arm_mujoco.robot.diff_drive import DiffDriveBaseGroup
from trossen_arm_mujoco.robot.gripper_group import GripperGroup
from trossen_arm_mujoco.robot.kinematics import Kinematics
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin
from trossen_arm_mujoco.robot.move_group import MoveGroup

__all__ = [
    "CONTROLLERS",
    "BaseVelocityController",
    "Controller",
    "EEDeltaController",
    "EEPoseController",
    "JointPosController",
    "JointRelPosController",
    "make_controller",
]

if TYPE_CHECKING:
    from trossen_arm_mujoco.robot.safety_floor import SafetyFloor


class Controller:
    """Base: maps a command of ``command_dim`` values to the group's control vector.

    Args:
        group: the move group it drives.
        model: compiled model.
        ctrl_dt: control period (s), the time between two ``compute`` calls. None: not known
            yet; a ``Robot`` running the controller sets its own, standalone the model
            timestep is used.
    """

    command_mode: ClassVar[str] = ""
    relative: ClassVar[bool] = False  # command taken against the state once, then its target held
    scale_step: ClassVar[bool] = False  # rate-limit by one factor for all values (IK modes)
    #: the robot's safety floor (``Robot.set_safety_floor`` hands it over); None: none
    floor: SafetyFloor | None = None

    def __init__(self, group: MoveGroup, model: mujoco.MjModel, ctrl_dt: float | None = None):
        self.group = group
        self.model = model
        if ctrl_dt is not None and not (np.isfinite(ctrl_dt) and ctrl_dt > 0):
            raise UserError(f"{group.name}: ctrl_dt must be a positive number of seconds")
        self.ctrl_dt = None if ctrl_dt is None else float(ctrl_dt)
        self._step_key: tuple | None = None  # (velocity limits, dt) the cached step is for
        self._step: np.ndarray | None = None
        self._neg_step: np.ndarray | None = None
        self._dim: int | None = None

    @property
    def command_dim(self) -> int:
        """Number of values in one command (the group's ``ctrl_dim`` for joint modes)."""
        return self.group.ctrl_dim

    def command_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of a command, two (command_dim,) arrays in the command's units
        (rad / m for joint positions)."""
        return tuple(self.group.ctrl_limits.T)

    @property
    def max_step(self) -> np.ndarray | None:
        """Most the control may move in one tick, (ctrl_dim,) rad or m; None: unlimited."""
        limits = self.group.velocity_limits
        if limits is None:
            return None
        dt = self.ctrl_dt if self.ctrl_dt is not None else float(self.model.opt.timestep)
        return limits * dt

    def _steps(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(``max_step``, its negative), cached until the limits or ``ctrl_dt`` change."""
        limits = self.group.velocity_limits
        dt = self.ctrl_dt if self.ctrl_dt is not None else float(self.model.opt.timestep)
        key = self._step_key
        if key is None or key[0] is not limits or key[1] != dt:
            self._step = None if limits is None else limits * dt
            self._neg_step = None if limits is None else -self._step
            self._step_key = (limits, dt)
        return self._step, self._neg_step

    def target(self, data: mujoco.MjData, command: np.ndarray) -> np.ndarray:
        """The control the command asks for, before rate limiting, (ctrl_dim,)."""
        return self._target(data, self._check(command))

    def _target(self, data: mujoco.MjData, cmd: np.ndarray) -> np.ndarray:
        """``target`` for a command already through ``_check``."""
        raise NotImplementedError

    def limit(self, data: mujoco.MjData, target: np.ndarray, ticks: int = 1) -> np.ndarray:
        """The control of this tick: from the applied control toward ``target`` by at most
        ``max_step`` per value, then clipped to the control range; (ctrl_dim,).

        Joint modes clip each value on its own; IK modes (``scale_step``) shrink the whole
        step by one factor instead, so that the tool keeps its Cartesian direction.

        Args:
            data: the state whose applied control (``group.get_ctrl(data)``) is the start.
            target: the control asked for, (ctrl_dim,) (rad or m; wheel speeds rad/s).
            ticks: where ``ticks`` calls in a row would take the control toward a fixed
                target (``max_step`` times ``ticks``), e.g. to check where a step of several
                ticks ends.
        """
        group = self.group
        step, neg_step = self._steps()
        if ticks != 1 and step is not None:
            step, neg_step = step * ticks, neg_step * ticks
        if step is None:
            u = np.array(target, dtype=float)
        else:
            current = group.get_ctrl(data)
            u = np.subtract(target, current, dtype=float)  # the step wanted
            if self.scale_step:
                u /= max(1.0, float((np.abs(u) / step).max()))
            else:  # the step limited to max_step, in place
                clip(u, neg_step, step, out=u)
            u += current
        # into the control range, in place
        return clip(u, group._ctrl_low, group._ctrl_high, out=u)

    def compute(self, data: mujoco.MjData, command: np.ndarray) -> np.ndarray:
        """The control of this tick for ``command`` (rate-limited), (ctrl_dim,)."""
        return self.limit(data, self.target(data, command))

    def _check(self, command: np.ndarray) -> np.ndarray:
        cmd = np.asarray(command, dtype=float).reshape(-1)
        if self._dim is None:
            self._dim = self.command_dim
        if cmd.shape[0] != self._dim:
            raise UserError(
                f"{self.group.name} ({self.command_mode}): expected {self.command_dim} values, "
                f"got {cmd.size}"
            )
        # cmd.cmd is finite iff every value is (or a huge one overflowed: check exactly then)
        if not math.isfinite(cmd.dot(cmd)) and not np.isfinite(cmd).all():
            raise UserError(f"{self.group.name}: command contains NaN or inf")
        return cmd


def _actuated_qpos(group: MoveGroup, data: mujoco.MjData) -> np.ndarray:
    """Current position of what the group's control drives."""
    return group.get_noop_ctrl(data)


class JointPosController(Controller):
    """``joint_position``: the command is the absolute joint target.

    Args:
        group: the move group it drives.
        model: compiled model.
        ctrl_dt: control period (s); None: see :class:`Controller`.
    """

    command_mode = "joint_position"

    def __init__(self, group, model, ctrl_dt=None):
        if not isinstance(group, (SimplyActuatedMoveGroup, GripperGroup)):
            raise UserError(f"{group.name}: joint_position needs joint actuators")
        super().__init__(group, model, ctrl_dt)

    def _target(self, data, cmd):
        return cmd


class JointRelPosController(JointPosController):
    """``joint_rel_position``: the command is added to the current joint positions."""

    command_mode = "joint_rel_position"
    relative = True

    def command_limits(self):
        """(low, high) of a relative command: +- the span of each control range
        (rad / m), two (command_dim,) arrays."""
        low, high = self.group.ctrl_limits.T
        span = high - low
        return -span, span

    def _target(self, data, cmd):
        group = self.group
        q = _actuated_qpos(group, data) + cmd
        return clip(q, group._ctrl_low, group._ctrl_high)


class EEPoseController(Controller):
    """``ee_pose``: tool-frame pose; passed to a mocap body, or solved by IK for joint arms.

    Args:
        group: the move group it drives.
        model: compiled model.
        ctrl_dt: control period (s); None: see :class:`Controller`.
    """

    command_mode = "ee_pose"
    scale_step = True

    def __init__(self, group, model, ctrl_dt=None):
        if not isinstance(group, MJCFFrameMixin):
            raise UserError(f"{group.name}: ee_pose needs a tool frame")
        super().__init__(group, model, ctrl_dt)
        self._kin = None
        if not isinstance(group, MocapArmGroup):
            self._kin = Kinematics(
                model, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range
            )

    @property
    def command_dim(self) -> int:
        """7: the tool pose [x, y, z (m), quat wxyz]."""
        return 7

    def command_limits(self):
        """(low, high) of a pose command: +-2 m per position, +-1 per quaternion component."""
        return np.array([-2.0, -2.0, -2.0, -1, -1, -1, -1]), np.array([2.0, 2.0, 2.0, 1, 1, 1, 1])

    def _target(self, data, cmd):
        floor = self.floor
        if floor is not None and cmd[2] < floor.floor_z:  # the tool frame kept above it
            cmd = cmd.copy()
            # a mocap arm's control is its tool-frame pose: no lower than it was asked to be
            was = self.group.get_ctrl(data)[2] if self._kin is None else None
            cmd[2] = floor.tool_height(data, self.group, cmd[2], was)
        if self._kin is None:
            return cmd
        q, _ = self._kin.solve(data.qpos, cmd[:3], cmd[3:], iterations=30)
        return q

    def limit(self, data, target, ticks=1):
        """As :meth:`Controller.limit`; a mocap arm's pose passes as is.

        Args:
            data: the state whose applied control is the start.
            target: the control asked for: joint targets (rad), or the mocap pose.
            ticks: the number of ticks toward ``target``.
        """
        if self._kin is None:
            return np.asarray(target, dtype=float)  # the mocap pose, as is
        return super().limit(data, target, ticks)


class EEDeltaController(Controller):
    """``ee_delta``: Cartesian delta of the tool frame through differential IK.

    Args:
        group: a joint-actuated arm with a tool frame.
        model: compiled model.
        rotation: the command also holds a rotation vector (6 values instead of 3).
        ctrl_dt: control period (s); None: see :class:`Controller`.
    """

    command_mode = "ee_delta"
    relative = True
    scale_step = True

    def __init__(self, group, model, rotation: bool = False, ctrl_dt: float | None = None):
        if not isinstance(group, MJCFFrameMixin) or not isinstance(group, SimplyActuatedMoveGroup):
            raise UserError(f"{group.name}: ee_delta needs a joint-actuated arm with a tool frame")
        super().__init__(group, model, ctrl_dt)
        self.rotation = rotation
        self.kinematics = Kinematics(
            model, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range
        )

    @property
    def command_dim(self) -> int:
        """3 ([dx, dy, dz] m) or, with ``rotation``, 6 (plus a rotation vector, rad)."""
        return 6 if self.rotation else 3

    def command_limits(self):
        """(low, high) of a delta: +-0.05 m per axis, +-0.2 rad per rotation component."""
        lim = np.full(self.command_dim, 0.05)
        if self.rotation:
            lim[3:] = 0.2
        return -lim, lim

    def _target(self, data, cmd):
        floor = self.floor
        if floor is not None:  # the tool frame's target height kept above the floor
            z = float(data.site_xpos[self.group.frame_site_id, 2])
            if z + cmd[2] < floor.floor_z:
                cmd = cmd.copy()
                cmd[2] = floor.tool_height(data, self.group, z + cmd[2]) - z
        return self.kinematics.delta_step(data.qpos, cmd)


class BaseVelocityController(Controller):
    """``base_velocity``: [x.vel (m/s), theta.vel (rad/s)] of a differential-drive base; the
    control is its two wheel speeds (rad/s, ``DiffDriveBaseGroup.wheel_speeds``).

    Out-of-limit commands are clipped, as the real base does (trossen_slate's
    ``set_cmd_vel`` clips to +-1.0 m/s and +-1.0 rad/s): each value to the group's
    ``base_limits``; then a command whose wheel speeds would exceed the wheels' limit (their
    actuators' ``ctrlrange``) is scaled down as a whole, keeping its curvature. Each command
    changed so counts in ``clipped_commands``; ``last_clipped`` says whether the latest was.
    A command holds until the next one (the real base stops after 300 ms without one; the
    simulation does not time out).

    Ramp: with ``base_limits.acceleration`` (m/s^2 at the wheel rims), each tick moves the
    applied wheel speeds toward the command's by at most ``acceleration / wheel_radius *
    ctrl_dt`` rad/s, both by one factor (``scale_step``), so that the base keeps the
    command's curvature while it speeds up; like the other controllers it keeps no state
    (it starts from the control applied in ``data``).

    Args:
        group: a differential-drive base group (``DiffDriveBaseGroup``).
        model: compiled model.
        ctrl_dt: control period (s); None: see :class:`Controller`.
    """

    command_mode = "base_velocity"
    scale_step = True  # both wheels ramp by one factor: the path's curvature is kept

    def __init__(self, group, model, ctrl_dt=None):
        if not isinstance(group, DiffDriveBaseGroup):
            raise UserError(f"{group.name}: base_velocity needs a differential-drive base group")
        super().__init__(group, model, ctrl_dt)
        self.clipped_commands = 0
        self.last_clipped = False

    @property
    def command_dim(self) -> int:
        """2: [x.vel (m/s), theta.vel (rad/s)]."""
        return 2

    def command_limits(self):
        """(low, high) of a command: -+ the base limits [x.vel m/s, theta.vel rad/s] (+-inf
        where the group has none)."""
        limits = self.group.base_limits
        high = np.full(2, np.inf) if limits is None else np.array([limits.x_vel, limits.theta_vel])
        return -high, high

    def executed(self, command) -> np.ndarray:
        """(2,) the [x.vel, theta.vel] the base executes for ``command``: clipped to the base
        limits, then scaled down as a whole where a wheel would exceed its speed limit."""
        low, high = self.command_limits()
        cmd = np.clip(np.asarray(command, dtype=float), low, high)
        group = self.group
        wheel_max = np.minimum(-group._ctrl_low, group._ctrl_high)
        peak = float((np.abs(group.wheel_speeds(*cmd)) / wheel_max).max())
        return cmd / peak if peak > 1.0 else cmd

    def _check(self, command):
        cmd = super()._check(command)
        done = self.executed(cmd)
        self.last_clipped = bool((done != cmd).any())
        self.clipped_commands += self.last_clipped
        return done

    def _target(self, data, cmd):
        return self.group.wheel_speeds(cmd[0], cmd[1])

    @property
    def max_step(self) -> np.ndarray | None:
        """Most the wheel speeds change in one tick, (2,) rad/s; None: no ramp."""
        return self._steps()[0]

    def _steps(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(wheel speed step per tick, its negative) from the base's acceleration limit,
        cached until the limits or ``ctrl_dt`` change; (None, None) without one."""
        group = self.group
        limits = group.base_limits
        dt = self.ctrl_dt if self.ctrl_dt is not None else float(self.model.opt.timestep)
        key = self._step_key
        if key is None or key[0] is not limits or key[1] != dt:
            acc = None if limits is None else limits.acceleration
            self._step = None if acc is None else np.full(2, acc / group.wheel_radius * dt)
            self._neg_step = None if acc is None else -self._step
            self._step_key = (limits, dt)
        return self._step, self._neg_step


CONTROLLERS: dict[str, type[Controller]] = {
    c.command_mode: c
    for c in (
        JointPosController,
        JointRelPosController,
        EEPoseController,
        EEDeltaController,
        BaseVelocityController,
    )
}


def make_controller(
    mode: str, group: MoveGroup, model: mujoco.MjModel, ctrl_dt: float | None = None
) -> Controller:
    """The controller for a command mode.

    Args:
        mode: a command mode (``joint_position``, ``joint_rel_position``, ``ee_pose``,
            ``ee_delta``, ``base_velocity``).
        group: the move group it drives.
        model: compiled model.
        ctrl_dt: control period (s); None: see :class:`Controller`.

    Raises:
        UserError: an unknown mode (listing the valid ones), or one the group cannot take.
    """
    if mode not in CONTROLLERS:
        raise unknown_name_error("command mode", mode, CONTROLLERS)
    return CONTROLLERS[mode](group, model, ctrl_dt=ctrl_dt)
