"""Waypoint trajectories for scripted policies: (t, xyz, quat, gripper), interpolation, noise.

A waypoint is a dict ``{"t": step, "xyz": (3,) m, "quat": (4,) wxyz, "gripper": m}``, with
poses of the arm's tool frame (``ee_site``) in the world frame and the gripper as finger
travel (0 closed .. 0.044 open). Between waypoints, positions and gripper interpolate
linearly and orientations by slerp.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.tasks.task import DEFAULT_POLICY_DT

__all__ = [
    "ARM_EE",
    "GRIPPER_PLAN_SPEED",
    "ArmWaypointPolicy",
    "BimanualWaypointPolicy",
    "Waypoint",
    "add_position_noise",
    "check_waypoints",
    "interpolate",
    "steps_for",
    "waypoint",
]

Waypoint = dict


def waypoint(t: float, xyz, quat, gripper: float) -> Waypoint:
    """Build a waypoint dict with float arrays.

    Args:
        t: the step the waypoint is reached at.
        xyz: (3,) tool-frame position (m, world frame).
        quat: (4,) tool-frame orientation, quaternion wxyz.
        gripper: the gripper value (m, finger travel).
    """
    return {
        "t": float(t),
        "xyz": np.asarray(xyz, dtype=float).copy(),
        "quat": np.asarray(quat, dtype=float).copy(),
        "gripper": float(gripper),
    }


def check_waypoints(waypoints: Sequence[Waypoint], name: str) -> None:
    """Times must start at 0 and increase strictly; every value finite."""
    if not waypoints:
        raise UserError(f"{name}: no waypoints")
    times = [w["t"] for w in waypoints]
    if times[0] != 0 or any(b <= a for a, b in zip(times, times[1:])):
        raise UserError(f"{name}: waypoint times must start at 0 and increase, got {times}")
    for w in waypoints:
        values = np.concatenate([w["xyz"], w["quat"], [w["gripper"]]])
        if not np.all(np.isfinite(values)):
            raise UserError(f"{name}: waypoint at t={w['t']} has NaN or inf")


def interpolate(waypoints: Sequence[Waypoint], t: float) -> np.ndarray:
    """Pose and gripper at time ``t``: [x, y, z, qw, qx, qy, qz, gripper] (8,).

    Before the first / after the last waypoint the end values are held.
    """
    if t <= waypoints[0]["t"]:
        w = waypoints[0]
        return np.concatenate([w["xyz"], Quaternion(w["quat"]).normalised.elements, [w["gripper"]]])
    for prev, nxt in zip(waypoints, waypoints[1:]):
        if prev["t"] <= t <= nxt["t"]:
            frac = (t - prev["t"]) / (nxt["t"] - prev["t"])
            xyz = prev["xyz"] + frac * (nxt["xyz"] - prev["xyz"])
            quat = Quaternion.slerp(Quaternion(prev["quat"]), Quaternion(nxt["quat"]), frac)
            grip = prev["gripper"] + frac * (nxt["gripper"] - prev["gripper"])
            return np.concatenate([xyz, quat.elements, [grip]])
    w = waypoints[-1]
    return np.concatenate([w["xyz"], Quaternion(w["quat"]).normalised.elements, [w["gripper"]]])


def add_position_noise(
    waypoints: Sequence[Waypoint], rng: np.random.Generator, scale: float, skip_first: bool = True
) -> list[Waypoint]:
    """Copies of the waypoints with xyz += U(-scale, scale) per axis (m).

    Args:
        waypoints: the plan.
        rng: the generator of the noise.
        scale: the noise's half range (m).
        skip_first: keep the first waypoint (the start pose) as it is.
    """
    out = []
    for i, w in enumerate(waypoints):
        w = dict(w)
        if not (skip_first and i == 0):
            w["xyz"] = w["xyz"] + rng.uniform(-scale, scale, size=3)
        out.append(w)
    return out


#: Planned gripper speed of the scripted policies: 80 % of the real carriage's speed limit
#: (0.0875 m/s), so recordings replay on the real arm at their own rate.
GRIPPER_PLAN_SPEED: float = 0.8 * JOINT_VELOCITY_LIMITS["left_carriage_joint"]


def steps_for(distance: float, speed: float, dt: float = DEFAULT_POLICY_DT) -> int:
    """Whole policy steps to cover ``distance`` at ``speed`` at most.

    Args:
        distance: the distance (m, or rad).
        speed: the highest speed (per second).
        dt: seconds per policy step.
    """
    return int(np.ceil(abs(distance) / (speed * dt)))


class BimanualWaypointPolicy:
    """Base of the scripted bimanual policies of the end-effector env.

    Called with a time step whose ``observation`` has ``mocap_pose_left``,
    ``mocap_pose_right`` (tool poses) and ``env_state``; returns the 16-value EE action
    ``[left xyz, left quat wxyz, left gripper, right xyz, right quat, right gripper]``. On the
    first call ``generate_trajectory(ts_first)`` builds ``left_trajectory`` and
    ``right_trajectory`` from the subclass's ``plan(observation)``.

    Args:
        inject_noise: perturb waypoint positions (see the subclass), drawn from ``rng`` only.
        rng: ``np.random.Generator`` or int seed for the noise.
    """

    #: Steps the plan needs before the task can be judged.
    minimum_episode_len: int = 0

    def __init__(self, inject_noise: bool = False, rng: np.random.Generator | int | None = None):
        self.inject_noise = inject_noise
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.step_count = 0
        self.left_trajectory: list[Waypoint] = []
        self.right_trajectory: list[Waypoint] = []

    def plan(self, obs: dict) -> tuple[list[Waypoint], list[Waypoint]]:
        """(left, right) waypoint lists from the first observation."""
        raise NotImplementedError

    def generate_trajectory(self, ts_first) -> None:
        """Build ``left_trajectory`` and ``right_trajectory`` from the first time step."""
        left, right = self.plan(ts_first.observation)
        check_waypoints(left, "left trajectory")
        check_waypoints(right, "right trajectory")
        self.left_trajectory, self.right_trajectory = left, right

    def _jitter(self, point, scale: float) -> np.ndarray:
        """point + U(-scale, scale) per axis, from this policy's generator only."""
        point = np.asarray(point, dtype=float)
        return point + self.rng.uniform(-scale, scale, 3) if scale else point

    def __call__(self, ts) -> np.ndarray:
        """16-value EE action for the current step."""
        if self.step_count == 0:
            self.generate_trajectory(ts)
        left = interpolate(self.left_trajectory, self.step_count)
        right = interpolate(self.right_trajectory, self.step_count)
        self.step_count += 1
        return np.concatenate([left, right])


#: ``action_layout`` of a single arm's end-effector policy: its action is one arm's
#: ``[xyz (m), quat wxyz, gripper (m)]`` (8 values; ``collect.single_arm`` records it).
ARM_EE = "arm_ee"


class ArmWaypointPolicy:
    """Base of the scripted policies of a single wxai arm (``collect.single_arm``).

    Called with the policy observation of the episode (a dict: the task's observation parts,
    ``ee_pose`` (7,) the tool frame [xyz m, quat wxyz] in the world frame, ``env_state``
    (7 per object: [xyz m, quat wxyz]) and, for a goal-conditioned task, ``goal`` (3,) m);
    returns the 8-value EE action ``[xyz (m), quat wxyz, gripper (m)]`` of the tool frame
    (``ee_site``) in the world frame, gripper = finger travel (0 closed .. 0.044 open). On the
    first call ``plan(obs)`` builds ``trajectory``; the plan is open loop.

    Args:
        inject_noise: perturb waypoint positions (see the subclass), drawn from ``rng`` only.
        rng: ``np.random.Generator`` or int seed for the noise.
    """

    #: The layout of its actions: one arm's tool pose and gripper (recorded in two phases).
    action_layout: str = ARM_EE
    #: Steps the plan needs before the task can be judged.
    minimum_episode_len: int = 0

    def __init__(self, inject_noise: bool = False, rng: np.random.Generator | int | None = None):
        self.inject_noise = inject_noise
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.step_count = 0
        self.trajectory: list[Waypoint] = []

    def plan(self, obs: dict) -> list[Waypoint]:
        """The arm's waypoints from the first observation."""
        raise NotImplementedError

    def _jitter(self, point, scale: float) -> np.ndarray:
        """point + U(-scale, scale) per axis, from this policy's generator only."""
        point = np.asarray(point, dtype=float)
        return point + self.rng.uniform(-scale, scale, 3) if scale else point

    def __call__(self, obs: dict) -> np.ndarray:
        """The (8,) EE action of the current step."""
        if self.step_count == 0:
            trajectory = self.plan(obs)
            check_waypoints(trajectory, f"{type(self).__name__} trajectory")
            self.trajectory = trajectory
        action = interpolate(self.trajectory, self.step_count)
        self.step_count += 1
        return action
