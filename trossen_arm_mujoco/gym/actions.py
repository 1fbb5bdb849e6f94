"""Normalized gym actions -> robot commands, with the safety floor.

Every action dimension lies in [-1, 1] (values outside are clipped). Per arm, in the
sampler's ``arms`` order:

- ``joint_position``: 6 values mapped linearly onto the joint control range (rad).
- ``joint_rel_position``: 6 joint deltas, times ``joint_rel_limit`` (rad).
- ``ee_delta``: 3 tool-frame deltas [dx, dy, dz] in the world frame, times
  ``ee_delta_limit`` (m), through the robot layer's differential IK; with
  ``hold_orientation`` the IK also turns the tool back to its orientation at reset.

then 1 gripper value: -1 closed .. +1 open (finger travel over the actuator range, m).

Safety floor (``gym.safety``): every collision geom of each arm (links, wrist, fingers) and
its tool frame (``ee_site``) are kept above ``table_height + safety_margin`` (m). What is
checked is where the arm's joint targets will be at the end of the step: in the joint modes
the controller moves them from the applied control toward the commanded target by at most
the joint speed limits times ``policy_dt``; with ``ee_delta`` (after the tool frame's target
height is clamped) it is the joint target of the IK step the controller will take. One
forward kinematics pass puts every arm there; an arm with a point below the floor gets the
exact rule (``SafetyFloor.offender``), and its move from the joints now is shortened
(halving it, down to no move) until every link stays above the floor (or, for an arm already
below it, goes no lower). So an arm commanded into the table moves toward it at its speed
limits and stops at the floor. The step reports ``safety_clipped`` and the links that would
have gone below (``clipped_links``).

In ``joint_position`` mode the actions on the control ranges are the joint targets of every
arm and gripper, in the order of the robot's ``JointTargetBatch`` over them
(``Robot.joint_target_batch``): the end of the step is that batch's ``preview``, and the
commands go to the robot as ``JointTargets``, one vector it takes as is. The controls are
those of commanding each group on its own (tested bit for bit), in fewer operations.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.gym.safety import SafetyFloor
from trossen_arm_mujoco.robot.joint_target_batch import JointTargets
from trossen_arm_mujoco.robot.kinematics import Kinematics, orientation_error
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.robot.selection import as_slice
from trossen_arm_mujoco.tasks.config_schema import KEYS

ACTION_MODES = ("joint_position", "joint_rel_position", "ee_delta")
#: rotation correction per step when holding the tool orientation (rad).
MAX_ROTATION_STEP = 0.2
#: fractions of a joint move tried when the full move would cross the safety floor.
BACKOFF = (0.5, 0.25, 0.125, 0.0)
#: config keys the mapper reads, checked once at construction (``tasks.config_schema``).
CONFIG_KEYS = ("table_height", "safety_margin", "ee_delta_limit", "joint_rel_limit", "policy_dt")


def _checked(config: Mapping[str, Any]) -> dict[str, Any]:
    """The values of ``CONFIG_KEYS`` in ``config``, checked: a NaN floor would switch the
    safety floor off, a negative limit would turn actions around."""
    out = {}
    for key in CONFIG_KEYS:
        if key not in config:
            raise UserError(f"action mapper: the task config has no key {key}; add it")
        out[key] = KEYS[key].check(f"action mapper config key {key}", config[key])
    out["hold_orientation"] = bool(config.get("hold_orientation", False))
    return out


class _ArmPart:
    """One arm and its gripper in the action vector, looked up once: action slices, the
    arm's qpos selection and controller, and the centre and half-width of the arm's and the
    gripper's control ranges."""

    def __init__(self, robot: Robot, arm, gripper, start: int, size: int):
        self.arm, self.gripper = arm, gripper
        self.controller = robot.controllers[arm.name]
        self.arm_values = slice(start, start + size - 1)
        self.grip_value = slice(start + size - 1, start + size)
        self.qpos_sel = as_slice(arm.qpos_idx)
        low, high = arm.ctrl_limits()
        self.a_mid, self.a_half = 0.5 * (low + high), 0.5 * (high - low)
        g_low, g_high = gripper.ctrl_limits()
        self.g_mid, self.g_half = 0.5 * (g_low + g_high), 0.5 * (g_high - g_low)


class ActionMapper:
    """Maps one flat action vector to ``{move group: command}`` for ``Robot.update_control``.

    Args:
        robot: the robot of the task's env (controllers built for ``mode``).
        arms: (arm group, gripper group) pairs, in action order.
        mode: one of ``ACTION_MODES``.
        config: task config; reads ``table_height``, ``safety_margin``, ``ee_delta_limit``,
            ``joint_rel_limit``, ``hold_orientation``.
    """

    def __init__(
        self, robot: Robot, arms: Sequence[tuple[str, str]], mode: str, config: Mapping[str, Any]
    ):
        if mode not in ACTION_MODES:
            raise unknown_name_error("action mode", mode, ACTION_MODES)
        config = _checked(config)
        self.robot = robot
        self.mode = mode
        self.floor_z = float(config["table_height"]) + float(config["safety_margin"])
        self.ee_limit = float(config["ee_delta_limit"])
        self.rel_limit = float(config["joint_rel_limit"])
        self.hold = bool(config.get("hold_orientation", False)) and mode == "ee_delta"
        view = robot.view
        self.arms = [(view.group(a), view.group(g)) for a, g in arms]
        # the ee_delta controller's own solver where there is one: the step predicted here
        # is the step it takes next (``Kinematics.delta_step`` keeps its last result)
        self.kin = {
            arm.name: getattr(robot.controllers.get(arm.name), "kinematics", None)
            or Kinematics(
                robot.model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range
            )
            for arm, _ in self.arms
        }
        self.floor = SafetyFloor(robot.model, [arm for arm, _ in self.arms], self.floor_z)
        #: links the safety floor held up in the last call (empty when none).
        self.clipped_links: list[str] = []
        self.ref_quat: dict[str, np.ndarray] = {}
        arm_dim = 3 if mode == "ee_delta" else 6
        self.sizes = [arm_dim + 1 for _ in self.arms]
        self.dim = sum(self.sizes)
        # per arm, looked up once (see _ArmPart); and the centre and half-width of every
        # action value's control range ([-1, 1] maps onto centre -/+ half-width) for the
        # joint modes, whose arm values are controls too
        self.n_ticks = int(round(float(config["policy_dt"]) / robot.ctrl_dt))
        self._parts: list[_ArmPart] = []
        self._part_of: dict[str, _ArmPart] = {}
        mids, halves, start = [], [], 0
        for (arm, gripper), size in zip(self.arms, self.sizes, strict=True):
            part = _ArmPart(robot, arm, gripper, start, size)
            self._parts.append(part)
            self._part_of[arm.name] = part
            mids += [part.a_mid if mode != "ee_delta" else np.zeros(size - 1), part.g_mid]
            halves += [part.a_half if mode != "ee_delta" else np.ones(size - 1), part.g_half]
            start += size
        self._mid, self._half = np.concatenate(mids), np.concatenate(halves)
        self._minus_one, self._one = -np.ones(self.dim), np.ones(self.dim)
        # joint_position: the action on the control ranges is the robot's joint target
        # vector of every arm and gripper, in this order
        self._batch_names = tuple(
            name for arm, gripper in self.arms for name in (arm.name, gripper.name)
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Action bounds: -1 and +1, float32 (dim,)."""
        return self._minus_one.astype(np.float32), self._one.astype(np.float32)

    def reset(self, data: mujoco.MjData) -> None:
        """Remember each tool orientation (held by ``hold_orientation``)."""
        self.ref_quat = {arm.name: arm.get_frame_pose(data)[3:] for arm, _ in self.arms}

    def __call__(
        self, data: mujoco.MjData, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], bool]:
        """(commands by move group, whether the safety floor changed the action)."""
        a = np.asarray(action, dtype=np.float64)
        if a.ndim != 1:
            a = a.reshape(-1)
        if a.shape[0] != self.dim:
            raise UserError(f"action must have {self.dim} values, got {a.size}")
        # a.a is finite iff every value is (or a huge one overflowed: check exactly then);
        # ndarray.dot on small vectors is a fraction of the cost of the @ operator
        if not math.isfinite(a.dot(a)) and not np.isfinite(a).all():
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        a = clip(a, self._minus_one, self._one)  # arrays: faster than scalars
        scaled = self._mid + self._half * a  # onto the control ranges (ee_delta arm: as is)
        if self.mode == "joint_position":
            batch = self.robot.joint_target_batch(self._batch_names)
            if batch is not None and batch.size == self.dim:
                return self._joint_targets(data, batch, scaled)
        # per arm: the command, and the joints now and at the end of the step it asks for
        steps = [
            self._ee_delta(data, part, scaled) if self.mode == "ee_delta"
            else self._joint_step(data, part, scaled, a)
            for part in self._parts
        ]  # fmt: skip
        held = self._hold_up(data, {p.arm.name: s[2] for p, s in zip(self._parts, steps)})
        commands: dict[str, np.ndarray] = {}
        links = self.clipped_links = []
        for part, (cmd, q_now, end, link) in zip(self._parts, steps):
            if part.arm.name in held:
                fraction, link = held[part.arm.name]
                cmd = self._shorten(cmd, q_now, end, fraction)
            commands[part.arm.name] = cmd
            if link:
                links.append(link)
            commands[part.gripper.name] = scaled[part.grip_value]
        return commands, bool(links)

    def _joint_targets(self, data, batch, target: np.ndarray) -> tuple[dict, bool]:
        """``joint_position`` with every arm and gripper in one ``JointTargetBatch``:
        ``target`` (dim,) is the batch's target vector (rad, m), the end of the step the
        batch's own ``preview`` over the step's ticks. Returns ``JointTargets`` of it (the
        robot takes the vector as is) and whether the floor changed it."""
        # kept: unless the floor changes it, this target goes to the robot as it is, and the
        # first tick writes the controls previewed here
        end = batch.preview(data, target, self.n_ticks, keep=True)
        held = self._hold_up(data, {p.arm.name: end[p.arm_values] for p in self._parts})
        links = self.clipped_links = []
        if held:
            target = target.copy()  # a new target: the kept preview no longer applies
        for name, (fraction, link) in held.items():
            part = self._part_of[name]
            q_now = data.qpos[part.qpos_sel]
            target[part.arm_values] = self._shorten(None, q_now, end[part.arm_values], fraction)
            links.append(link)
        return JointTargets(batch, target), bool(links)  # finite and of its size already

    def _hold_up(self, data, ends: dict[str, np.ndarray]) -> dict[str, tuple[float, str]]:
        """The arms the safety floor holds up when each arm's joints end the step at
        ``ends[arm]`` (rad): arm -> (fraction of its move from the joints now that is safe,
        link that would have gone below). One forward kinematics pass for every arm; the
        exact rule only for an arm whose step ends with a point below the floor."""
        below = self.floor.below(data.qpos, ends)
        held: dict[str, tuple[float, str]] = {}
        for name in below:
            part = self._part_of[name]
            fraction, link = self._safe_fraction(
                data, part.arm, data.qpos[part.qpos_sel], ends[name]
            )
            if link:
                held[name] = (fraction, link)
        return held

    # -- per mode: (command, joints now, joints at the end of the step, link held or "") ---
    def _joint_step(self, data, part: _ArmPart, scaled, a) -> tuple:
        """Joint modes. ``scaled``, ``a``: the whole action on the control ranges (rad) and
        in [-1, 1]. The end of the step is where the arm's joint targets will be: the
        controller moves them from the applied control toward the commanded target by at
        most the joint speed limits times ``policy_dt``."""
        q_now = data.qpos[part.qpos_sel]
        if self.mode == "joint_position":
            cmd = target = scaled[part.arm_values]
        else:  # joint_rel_position: [-1, 1] times joint_rel_limit, from the joints now
            cmd = a[part.arm_values] * self.rel_limit
            target = q_now + cmd
        # the controller's own rate limit, over the step's ticks
        return cmd, q_now, part.controller.limit(data, target, self.n_ticks), ""

    def _ee_delta(self, data, part: _ArmPart, scaled) -> tuple:
        """``ee_delta``: the tool frame's target height clamped to the floor; the end of the
        step is the joint target of the IK step the controller will take."""
        arm = part.arm
        z = data.site_xpos[arm.frame_site_id, 2]
        delta = scaled[part.arm_values] * self.ee_limit
        link = ""
        if z + delta[2] < self.floor_z:
            delta[2] = min(self.floor_z - z, self.ee_limit)
            link = self.floor.link_name(int(self.robot.model.site_bodyid[arm.frame_site_id]))
        twist = delta
        if self.hold:
            quat = arm.get_frame_pose(data)[3:]
            ref = self.ref_quat.get(arm.name, quat)
            rot = np.clip(orientation_error(ref, quat), -MAX_ROTATION_STEP, MAX_ROTATION_STEP)
            twist = np.concatenate([delta, rot])
        q_now = data.qpos[part.qpos_sel]
        return twist, q_now, self.kin[arm.name].delta_step(data.qpos, twist), link

    def _shorten(self, cmd, q_now, end, fraction: float) -> np.ndarray:
        """The command that takes ``fraction`` of the step from the joints now."""
        if self.mode == "ee_delta":
            return cmd * fraction  # the twist, scaled
        safe = q_now + fraction * (end - q_now)
        return safe if self.mode == "joint_position" else safe - q_now

    def _safe_fraction(self, data, arm, q_now, target) -> tuple[float, str]:
        """(Largest tried fraction of the move that keeps the arm's links above the floor (see
        ``SafetyFloor.offender``), name of the offending link at the full move when that is
        not 1, else "")."""
        floor, name = self.floor, arm.name
        z_now, lag = floor.now(data, name)  # body poses of data: no forward kinematics
        body = floor.offender(name, floor.heights(data.qpos, name, target), z_now, lag)
        if body < 0:
            return 1.0, ""
        for fraction in BACKOFF[:-1]:
            q = q_now + fraction * (target - q_now)
            if floor.offender(name, floor.heights(data.qpos, name, q), z_now, lag) < 0:
                return fraction, floor.link_name(body)
        return 0.0, floor.link_name(body)
