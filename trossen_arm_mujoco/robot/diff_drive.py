"""Differential-drive bases: a robot base on a free joint, moved by two driven wheels.

``DiffDriveBaseGroup`` is the base move group of a wheeled robot (the Mobile AI's SLATE base):
its ``pose`` is the free joint's (the robot frame), its control the two wheel speeds
[left, right] (rad/s). Body velocities as the real base takes them (``x.vel`` forward, m/s;
``theta.vel`` yaw rate, rad/s, counter-clockwise from above) map to wheel speeds with wheel
radius r and track b: ``left = (x.vel - theta.vel b / 2) / r``, ``right = (x.vel + theta.vel
b / 2) / r`` (positive drives forward). The ``base_velocity`` controller keeps commands within
``BaseVelocityLimits``. Units m, rad, s; poses in the world frame (4x4, or 7 values
[x, y, z, qw, qx, qy, qz]); ``planar_pose`` is (x, y, yaw) on the floor.

Docs: docs/concepts/models.md (The base in the robot layer).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.base_group import RobotBaseGroup
from trossen_arm_mujoco.robot.checks import vector
from trossen_arm_mujoco.robot.frames import (
    as_transform,
    frame_jacobian,
    pose7_to_transform,
    transform_to_pose7,
)
from trossen_arm_mujoco.robot.joint_indices import FREE, HINGE, actuator_ids
from trossen_arm_mujoco.robot.limits import frozen
from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["BaseVelocityLimits", "DiffDriveBaseGroup"]


@dataclass(frozen=True)
class BaseVelocityLimits:
    """The most a differential-drive base is commanded to move.

    x_vel: forward/backward speed, m/s (commands beyond +-x_vel are clipped to it).
    theta_vel: yaw rate, rad/s (clipped likewise).
    acceleration: the most each wheel's rim speeds up or slows down, m/s^2 (so the base's
        x.vel changes by at most this, its theta.vel by at most 2 * acceleration / track
        rad/s^2): the wheel speeds ramp toward a new command, both by one factor, keeping
        the command's curvature while they ramp. None: no ramp (the wheels' torque alone
        limits the acceleration).
    The wheels' own limit (their actuators' ``ctrlrange``, rad/s) applies on top: a command
    whose wheel speeds exceed it is scaled down as a whole, keeping its curvature.
    """

    x_vel: float
    theta_vel: float
    acceleration: float | None = None

    def __post_init__(self) -> None:
        for name in ("x_vel", "theta_vel", "acceleration"):
            value = getattr(self, name)
            if value is None and name == "acceleration":
                continue
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise UserError(f"base velocity limit {name} must be a number > 0, got {value!r}")


class DiffDriveBaseGroup(RobotBaseGroup):
    """A base on a free joint driven by two wheels with velocity actuators.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "base").
        free_joint: the base body's free joint.
        wheel_joints: (left, right) hinge joints of the driven wheels.
        wheel_actuators: (left, right) velocity actuators of those wheels (ctrl in rad/s).
        wheel_radius: rolling radius (m).
        track: distance between the wheels (m); default from the model (the wheel bodies'
            distance along the base's y).

    ``joint_pos`` is (9,): the free joint's 7 values, then the two wheel angles (rad);
    ``joint_vel`` (8,): the free joint's 6 dofs (linear world, angular body frame), then the
    two wheel speeds. The control is (2,) wheel speeds [left, right], rad/s; the no-op
    control is zero (the base stops).
    """

    joint_types = (FREE, HINGE)

    def __init__(
        self,
        model,
        name: str,
        free_joint: str,
        wheel_joints: tuple[str, str],
        wheel_actuators: tuple[str, str],
        wheel_radius: float,
        track: float | None = None,
    ):
        m = model.model if isinstance(model, mujoco.MjData) else model
        jid = lookup_id(m, "joint", free_joint)
        if int(m.jnt_type[jid]) != FREE:
            raise UserError(f"move group '{name}': joint '{free_joint}' is not a free joint")
        if len(wheel_joints) != 2 or len(wheel_actuators) != 2:
            raise UserError(f"move group '{name}': a differential drive has two wheels")
        super().__init__(model, name, int(m.jnt_bodyid[jid]), [free_joint, *wheel_joints])
        if int(self.model.jnt_type[self.joint_ids[1]]) != HINGE:
            raise UserError(f"move group '{name}': wheel joints must be hinges")
        self._pose_sel = as_slice(self.qpos_idx[:7])
        self.actuator_ids = actuator_ids(self.model, wheel_actuators)
        for aid, joint in zip(self.actuator_ids, self.joint_ids[1:]):
            if int(self.model.actuator_trnid[aid, 0]) != int(joint):
                raise UserError(
                    f"move group '{name}': actuator '{self.model.actuator(aid).name}' does not "
                    f"drive wheel '{self.model.joint(joint).name}'"
                )
        rng = self.model.actuator_ctrlrange[self.actuator_ids]
        self._ctrl_low, self._ctrl_high = frozen(rng[:, 0].copy()), frozen(rng[:, 1].copy())
        self._ctrl_sel = as_slice(self.actuator_ids)
        if not (np.isfinite(wheel_radius) and wheel_radius > 0):
            raise UserError(f"move group '{name}': wheel radius must be > 0 m, got {wheel_radius}")
        self.wheel_radius = float(wheel_radius)
        if track is None:
            bodies = [int(self.model.jnt_bodyid[j]) for j in self.joint_ids[1:]]
            track = abs(float(np.diff(self.model.body_pos[bodies, 1])[0]))
        if not (np.isfinite(track) and track > 0):
            raise UserError(f"move group '{name}': track must be > 0 m, got {track}")
        self.track = float(track)
        #: the most the base is commanded to move (``BaseVelocityController``); None: no
        #: limit but the wheels'
        self.base_limits: BaseVelocityLimits | None = None

    # -- the robot frame -----------------------------------------------------------------
    def get_transform(self, data):
        return pose7_to_transform(data.qpos[self._pose_sel])

    def set_transform(self, data, pose) -> None:
        """Put the base at ``pose`` (4x4 or 7 values); wheels and velocities are kept."""
        data.qpos[self._pose_sel] = transform_to_pose7(as_transform(f"{self.name} pose", pose))

    def get_jacobian(self) -> np.ndarray:
        """(6, nv) Jacobian of the base body's origin (its free joint moves it)."""
        return frame_jacobian(self.model, self.data, "body", self.body_id)

    def get_planar_pose(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) [x, y, yaw] of the base in the world (m, rad; yaw about world z)."""
        q = data.qpos[self._pose_sel]
        w, x, y, z = q[3:]
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return np.array([q[0], q[1], yaw])

    def set_planar_pose(self, data: mujoco.MjData, x: float, y: float, yaw: float) -> None:
        """Put the base upright at a planar pose, at its height at rest (the model's initial
        height of the base body); velocities are kept.

        Args:
            data: the state to write.
            x: world x of the base (m).
            y: world y of the base (m).
            yaw: heading about world z (rad, counter-clockwise from above).
        """
        z = float(self.model.qpos0[self.qpos_idx[2]])
        pose = [x, y, z, np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        data.qpos[self._pose_sel] = vector(f"{self.name} planar pose", pose, 7)

    # -- velocities ----------------------------------------------------------------------
    def wheel_speeds(self, x_vel: float, theta_vel: float) -> np.ndarray:
        """(2,) [left, right] wheel speeds (rad/s) for a forward speed (m/s) and a yaw rate
        (rad/s)."""
        half = 0.5 * self.track * theta_vel
        return np.array([x_vel - half, x_vel + half]) / self.wheel_radius

    def body_velocity(self, wheel_speeds) -> np.ndarray:
        """(2,) [x.vel (m/s), theta.vel (rad/s)] that wheel speeds [left, right] (rad/s)
        drive, rolling without slip (``wheel_speeds`` inverted)."""
        left, right = np.asarray(wheel_speeds, dtype=float) * self.wheel_radius
        return np.array([(left + right) / 2, (right - left) / self.track])

    def get_base_velocity(self, data: mujoco.MjData) -> np.ndarray:
        """(2,) the base's measured [x.vel, theta.vel]: its origin's speed along its heading
        (m/s) and its yaw rate (rad/s), from the free joint's velocity (what the real base
        reports with ``get_vel``)."""
        dof = self.dof_idx
        heading = pose7_to_transform(data.qpos[self._pose_sel])[:3, 0]
        return np.array([float(heading @ data.qvel[dof[:3]]), float(data.qvel[dof[5]])])

    # -- control -------------------------------------------------------------------------
    @property
    def ctrl_dim(self) -> int:
        return 2

    def get_ctrl(self, data):
        return data.ctrl[self._ctrl_sel].copy()

    def set_ctrl(self, data, ctrl):
        """Wheel speeds [left, right] (rad/s), clipped to the actuators' ``ctrlrange``."""
        c = vector(self.name, ctrl, 2)
        data.ctrl[self.actuator_ids] = np.clip(c, self._ctrl_low, self._ctrl_high)

    def _write_ctrl(self, data, ctrl):
        data.ctrl[self._ctrl_sel] = ctrl

    def get_noop_ctrl(self, data):
        """Zero wheel speeds: the base stops (2,)."""
        return np.zeros(2)
