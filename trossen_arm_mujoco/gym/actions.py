"""Normalized gym actions -> robot commands, with the safety floor.

Every action dimension lies in [-1, 1] (values outside are clipped). Per arm, in the
sampler's ``arms`` order:

- ``joint_position``: 6 values mapped linearly onto the joint control range (rad).
- ``joint_rel_position``: 6 joint deltas, times ``joint_rel_limit`` (rad).
- ``ee_delta``: 3 tool-frame deltas [dx, dy, dz] in the world frame, times
  ``ee_delta_limit`` (m), through the robot layer's differential IK; with
  ``hold_orientation`` the IK also turns the tool back to its orientation at reset.

then 1 gripper value: -1 closed .. +1 open (finger travel over the actuator range, m).

Safety floor: the tool frame (``ee_site``, at the fingertips) is kept above
``table_height + safety_margin`` (m). ``ee_delta`` clamps the target height; joint modes
check the target with forward kinematics and shorten the move (halving it, down to no move)
until the target is above the floor. Either way the step reports ``safety_clipped``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.kinematics import Kinematics, orientation_error
from trossen_arm_mujoco.robot.robot import Robot

ACTION_MODES = ("joint_position", "joint_rel_position", "ee_delta")
#: rotation correction per step when holding the tool orientation (rad).
MAX_ROTATION_STEP = 0.2
#: fractions of a joint move tried when the full move would cross the safety floor.
BACKOFF = (0.5, 0.25, 0.125, 0.0)


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
        self.robot = robot
        self.mode = mode
        self.floor_z = float(config["table_height"]) + float(config["safety_margin"])
        self.ee_limit = float(config["ee_delta_limit"])
        self.rel_limit = float(config["joint_rel_limit"])
        self.hold = bool(config.get("hold_orientation", False)) and mode == "ee_delta"
        view = robot.view
        self.arms = [(view.group(a), view.group(g)) for a, g in arms]
        self.kin = {
            arm.name: Kinematics(
                robot.model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range
            )
            for arm, _ in self.arms
        }
        self.ref_quat: dict[str, np.ndarray] = {}
        arm_dim = 3 if mode == "ee_delta" else 6
        self.sizes = [arm_dim + 1 for _ in self.arms]
        self.dim = sum(self.sizes)
        # per arm, looked up once: action slices, and the centre and half-width of the arm's
        # and the gripper's control ranges ([-1, 1] maps onto centre -/+ half-width)
        self._parts = []
        start = 0
        for (arm, gripper), size in zip(self.arms, self.sizes, strict=True):
            a_low, a_high = arm.ctrl_limits()
            g_low, g_high = gripper.ctrl_limits()
            self._parts.append((arm, gripper, start, start + size - 1,
                                0.5 * (a_low + a_high), 0.5 * (a_high - a_low),
                                0.5 * (g_low + g_high), 0.5 * (g_high - g_low)))  # fmt: skip
            start += size

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Action bounds: -1 and +1, float32 (dim,)."""
        return -np.ones(self.dim, np.float32), np.ones(self.dim, np.float32)

    def reset(self, data: mujoco.MjData) -> None:
        """Remember each tool orientation (held by ``hold_orientation``)."""
        self.ref_quat = {arm.name: arm.get_frame_pose(data)[3:] for arm, _ in self.arms}

    def __call__(
        self, data: mujoco.MjData, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], bool]:
        """(commands by move group, whether the safety floor changed the action)."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape[0] != self.dim:
            raise UserError(f"action must have {self.dim} values, got {a.size}")
        # a @ a is finite iff every value is (or a huge one overflowed: check exactly then)
        if not math.isfinite(a @ a) and not np.isfinite(a).all():
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        a = np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip(a, -1, 1), without its overhead
        commands: dict[str, np.ndarray] = {}
        clipped = False
        for arm, gripper, start, grip, a_mid, a_half, g_mid, g_half in self._parts:
            cmd, hit = self._arm_command(data, arm, a[start:grip], a_mid, a_half)
            commands[arm.name] = cmd
            clipped |= hit
            commands[gripper.name] = g_mid + g_half * a[grip : grip + 1]
        return commands, clipped

    # -- per mode -------------------------------------------------------------------------
    def _arm_command(self, data, arm, a, mid, half) -> tuple[np.ndarray, bool]:
        if self.mode == "ee_delta":
            return self._ee_delta(data, arm, a)
        q_now = arm.get_qpos(data)
        if self.mode == "joint_position":
            move = None
            target = mid + half * a
        else:
            move = a * self.rel_limit
            target = q_now + move
        fraction, hit = self._safe_fraction(data, arm, q_now, target)
        if not hit:
            return (target if move is None else move), False
        target = q_now + fraction * (target - q_now)
        return (target if move is None else target - q_now), True

    def _ee_delta(self, data, arm, a: np.ndarray) -> tuple[np.ndarray, bool]:
        z = data.site_xpos[arm.frame_site_id, 2]
        delta = a * self.ee_limit
        hit = False
        if z + delta[2] < self.floor_z:
            delta[2] = min(self.floor_z - z, self.ee_limit)
            hit = True
        if not self.hold:
            return delta, hit
        quat = arm.get_frame_pose(data)[3:]
        ref = self.ref_quat.get(arm.name, quat)
        rot = np.clip(orientation_error(ref, quat), -MAX_ROTATION_STEP, MAX_ROTATION_STEP)
        return np.concatenate([delta, rot]), hit

    def _safe_fraction(self, data, arm, q_now, target) -> tuple[float, bool]:
        """Largest tried fraction of the move whose tool frame stays above the floor."""
        kin = self.kin[arm.name]
        if kin.site_position(data.qpos, target)[2] >= self.floor_z:
            return 1.0, False
        for fraction in BACKOFF:
            q = q_now + fraction * (target - q_now)
            if kin.site_position(data.qpos, q)[2] >= self.floor_z:
                return fraction, True
        return 0.0, True
