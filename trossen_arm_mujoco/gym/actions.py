"""Normalized gym actions -> robot commands.

Every action value lies in [-1, 1] (values outside are clipped). Per arm, in the sampler's
``arms`` order: 6 values (``joint_position``: mapped linearly onto the joint control range,
rad; ``joint_rel_position``: joint deltas times ``joint_rel_limit``, rad; ``ee_delta``: 3
world-frame tool deltas [dx, dy, dz] times ``ee_delta_limit``, m, through the robot layer's
differential IK, with ``hold_orientation`` keeping the tool's orientation at reset), then 1
gripper value (-1 closed .. +1 open over the actuator range, m). A robot with a
differential-drive base adds 2 values: [x.vel, theta.vel] times the base's limits (m/s,
rad/s). The safety floor is the robot layer's (``robot.safety_floor``), not this module's.

Docs: docs/gym/index.md; design notes: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.gym.inputs import action_array, nonfinite_action
from trossen_arm_mujoco.robot.joint_target_batch import JointTargets
from trossen_arm_mujoco.robot.kinematics import orientation_error
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.tasks.config_schema import KEYS

__all__ = ["ACTION_MODES", "CONFIG_KEYS", "MAX_ROTATION_STEP", "ActionMapper"]

ACTION_MODES = ("joint_position", "joint_rel_position", "ee_delta")
#: rotation correction per step when holding the tool orientation (rad).
MAX_ROTATION_STEP = 0.2
#: dtype characters of the actions taken as they are (float32, float64).
_FLOAT_CHARS = "fd"
#: config keys the mapper reads, checked once at construction (``tasks.config_schema``).
CONFIG_KEYS = ("ee_delta_limit", "joint_rel_limit")


def _checked(config: Mapping[str, Any]) -> dict[str, Any]:
    """The values of ``CONFIG_KEYS`` in ``config``, checked: a negative limit would turn
    actions around."""
    out = {}
    for key in CONFIG_KEYS:
        if key not in config:
            raise UserError(f"action mapper: the task config has no key {key}; add it")
        out[key] = KEYS[key].check(f"action mapper config key {key}", config[key])
    out["hold_orientation"] = bool(config.get("hold_orientation", False))
    return out


class _ArmPart:
    """One arm and its gripper in the action vector, looked up once: action slices, and the
    centre and half-width of the arm's and the gripper's control ranges."""

    def __init__(self, arm, gripper, start: int, size: int):
        self.arm, self.gripper = arm, gripper
        self.arm_values = slice(start, start + size - 1)
        self.grip_value = slice(start + size - 1, start + size)
        low, high = arm.ctrl_limits.T
        self.a_mid, self.a_half = 0.5 * (low + high), 0.5 * (high - low)
        g_low, g_high = gripper.ctrl_limits.T
        self.g_mid, self.g_half = 0.5 * (g_low + g_high), 0.5 * (g_high - g_low)


class ActionMapper:
    """Maps one flat action vector to ``{move group: command}`` for ``Robot.update_control``.

    Args:
        robot: the robot of the task's env (controllers built for ``mode``).
        arms: (arm group, gripper group) pairs, in action order.
        mode: one of ``ACTION_MODES``.
        config: task config; reads ``ee_delta_limit``, ``joint_rel_limit``,
            ``hold_orientation``.
    """

    def __init__(
        self, robot: Robot, arms: Sequence[tuple[str, str]], mode: str, config: Mapping[str, Any]
    ):
        if mode not in ACTION_MODES:
            raise unknown_name_error("action mode", mode, ACTION_MODES)
        config = _checked(config)
        self.robot = robot
        self.mode = mode
        self.ee_limit = float(config["ee_delta_limit"])
        self.rel_limit = float(config["joint_rel_limit"])
        self.hold = bool(config["hold_orientation"]) and mode == "ee_delta"
        view = robot.view
        self.arms = [(view.get_move_group(a), view.get_move_group(g)) for a, g in arms]
        self.ref_quat: dict[str, np.ndarray] = {}
        arm_dim = 3 if mode == "ee_delta" else 6
        self.sizes = [arm_dim + 1 for _ in self.arms]
        self.dim = sum(self.sizes)
        self._shape = (self.dim,)
        # per arm, looked up once (see _ArmPart); and the centre and half-width of every
        # action value's control range ([-1, 1] maps onto centre -/+ half-width) for the
        # joint modes, whose arm values are controls too
        self._parts: list[_ArmPart] = []
        mids, halves, start = [], [], 0
        for (arm, gripper), size in zip(self.arms, self.sizes, strict=True):
            part = _ArmPart(arm, gripper, start, size)
            self._parts.append(part)
            mids += [part.a_mid if mode != "ee_delta" else np.zeros(size - 1), part.g_mid]
            halves += [part.a_half if mode != "ee_delta" else np.ones(size - 1), part.g_half]
            start += size
        # bases driven by velocity (the Mobile AI's): [x.vel, theta.vel] over their limits
        self._bases: list[tuple[str, slice]] = []
        for name, controller in robot.controllers.items():
            if controller.command_mode == "base_velocity":
                self._bases.append((name, slice(start, start + 2)))
                mids.append(np.zeros(2))
                halves.append(np.asarray(controller.command_limits()[1], dtype=float))
                start += 2
        self.dim = start
        self._shape = (self.dim,)
        self._mid, self._half = np.concatenate(mids), np.concatenate(halves)
        self._minus_one, self._one = -np.ones(self.dim), np.ones(self.dim)
        # joint_position: the action on the control ranges is the robot's joint target
        # vector of every arm and gripper, in this order
        self._batch_names = tuple(
            name for arm, gripper in self.arms for name in (arm.name, gripper.name)
        )
        self._batch = None  # the robot's JointTargetBatch over them (joint_position)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Action bounds: -1 and +1, float32 (dim,)."""
        return self._minus_one.astype(np.float32), self._one.astype(np.float32)

    def reset(self, data: mujoco.MjData) -> None:
        """Remember each tool orientation (held by ``hold_orientation``)."""
        self.ref_quat = {arm.name: arm.get_frame_pose(data)[3:] for arm, _ in self.arms}

    def __call__(self, data: mujoco.MjData, action: np.ndarray) -> dict[str, np.ndarray]:
        """Commands by move group for ``action`` (dim,) in [-1, 1] (clipped into it). A value
        that is not ``dim`` finite numbers is an ``InvalidInput`` (a UserError and a
        ValueError) naming the action space (``gym.inputs``). The safety floor acts in the
        robot, tick by tick: what it held up is ``robot.floor_report`` after the step
        (``gym.safety.safety_info``)."""
        # fast path: a float ndarray of the action's shape (what agents and samples give);
        # anything else is read and checked in ``gym.inputs`` (errors naming the space)
        if (
            type(action) is np.ndarray
            and action.shape == self._shape
            and action.dtype.char in _FLOAT_CHARS
        ):
            a = action if action.dtype.char == "d" else action.astype(np.float64)  # read only
        else:
            a = action_array(action, self.dim)
        # a.a is finite iff every value is (or a huge one overflowed: check exactly then);
        # ndarray.dot on small vectors is a fraction of the cost of the @ operator
        if not math.isfinite(a.dot(a)) and not np.isfinite(a).all():
            raise nonfinite_action(a, self.dim)
        a = clip(a, self._minus_one, self._one)  # arrays: faster than scalars
        scaled = self._mid + self._half * a  # onto the control ranges (ee_delta arm: as is)
        if self.mode == "joint_position":
            # the robot's batch over these groups, looked up again only when the robot has
            # built another (a controller or its limits changed); a batch gone stale in
            # between is refused by the robot, which then takes the commands one by one
            batch = self._batch
            if batch is None or self.robot.kept_batch(self._batch_names) is not batch:
                batch = self._batch = self.robot.joint_target_batch(self._batch_names)
            if batch is not None and batch.size == self.dim:
                return JointTargets(batch, scaled)  # finite and of its size already
        commands: dict[str, np.ndarray] = {}
        for part in self._parts:
            if self.mode == "ee_delta":
                arm_cmd = self._twist(data, part, scaled)
            elif self.mode == "joint_position":
                arm_cmd = scaled[part.arm_values]
            else:  # joint_rel_position: [-1, 1] times joint_rel_limit, from the joints now
                arm_cmd = a[part.arm_values] * self.rel_limit
            commands[part.arm.name] = arm_cmd
            commands[part.gripper.name] = scaled[part.grip_value]
        for name, values in self._bases:
            commands[name] = scaled[values]
        return commands

    def _twist(self, data, part: _ArmPart, scaled) -> np.ndarray:
        """``ee_delta``: the tool-frame delta (m), with the rotation back to the reset
        orientation (rad) when holding it."""
        delta = scaled[part.arm_values] * self.ee_limit
        if not self.hold:
            return delta
        arm = part.arm
        quat = arm.get_frame_pose(data)[3:]
        ref = self.ref_quat.get(arm.name, quat)
        rot = np.clip(orientation_error(ref, quat), -MAX_ROTATION_STEP, MAX_ROTATION_STEP)
        return np.concatenate([delta, rot])
