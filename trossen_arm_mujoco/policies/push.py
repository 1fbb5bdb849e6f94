"""Scripted push for the single wxai arm (task ``push``).

``PushPolicy(inject_noise=False, rng=None)`` is called with the policy observation of
``collect.single_arm`` (``ee_pose``, ``env_state`` = the cube pose, ``goal``) and returns the
8-value EE action ``[xyz (m), quat wxyz, gripper (m)]`` of the tool frame in the world frame.

The plan (world frame, steps of 0.02 s), built once from the first observation: with the
fingers closed and pointing down, turned so that their broad side faces the push direction
(cube -> goal), the tool goes ``BACK`` behind the cube at ``HOVER_Z``, descends to
``PUSH_Z``, pushes the cube at ``PUSH_SPEED`` until the cube's centre is on the goal, then
lifts away and holds.

Docs: docs/gym/WXAIPush-v0.md, docs/cli/record.md (Single-arm tasks).
"""

from __future__ import annotations

import math

import numpy as np

from trossen_arm_mujoco.policies.scripted import ArmWaypointPolicy, Waypoint, steps_for, waypoint
from trossen_arm_mujoco.quaternion import Quaternion

__all__ = [
    "BACK",
    "CONTACT",
    "FACE_YAW",
    "HOVER_Z",
    "PUSH_SPEED",
    "PUSH_Z",
    "PushPolicy",
    "tool_down",
    "tool_yaw",
    "wrap_angle",
]

#: Tool-frame (fingertip) height while pushing and while moving above the table (m). The
#: push is low: the finger pads start 13.5 mm above the fingertips, and a push at the
#: cube's upper half (friction 1.5) tips it over (at 12 mm: 3 of 10 seeds reached the goal;
#: at 2-8 mm 10 of 10, the cube tilting by at most 4 mm).
PUSH_Z = 0.005
HOVER_Z = 0.08
#: Where the push starts: this far behind the cube's centre, against the push (m).
BACK = 0.065
#: Distance from the tool frame to the cube's centre while pushing, along the push (m):
#: half the 40 mm cube plus the closed fingers' half thickness (measured: 0.029-0.040,
#: mean 0.033 over 30 seeds).
CONTACT = 0.033
#: Yaw of the push direction relative to the tool's z axis (rad): the fingers' closing axis
#: (tool y) along the push, their broad side against the cube.
FACE_YAW = math.pi / 2
#: Tool speeds (m/s): moving freely, and pushing.
MOVE_SPEED = 0.2
PUSH_SPEED = 0.1
#: Noise scales (m): free-space waypoints, and waypoints at the cube.
NOISE_FREE = 0.01
NOISE_CONTACT = 0.002


def wrap_angle(angle: float, period: float = 2 * math.pi) -> float:
    """``angle`` (rad) wrapped into [-period / 2, period / 2)."""
    return (angle + period / 2) % period - period / 2


def tool_down(yaw: float) -> np.ndarray:
    """Tool-frame orientation (quat wxyz) pointing down (tool x along world -z), its z axis
    at ``yaw`` (rad) about world z: the fingers close along (-sin yaw, cos yaw, 0)."""
    down = Quaternion(axis=[0, 1, 0], degrees=90)
    return (Quaternion(axis=[0, 0, 1], radians=yaw) * down).elements


def tool_yaw(quat: np.ndarray) -> float:
    """The yaw (rad) of a tool orientation: the heading of its z axis in the world xy plane
    (0 at the start pose, tool z along world +x)."""
    z = Quaternion(np.asarray(quat, dtype=float)).rotate([0.0, 0.0, 1.0])
    return float(math.atan2(z[1], z[0]))


class PushPolicy(ArmWaypointPolicy):
    """Push the cube onto the goal with the closed fingers (module docstring).

    Args:
        inject_noise: perturb waypoint positions (uniform, up to 1 cm in free space and
            2 mm at the cube), drawn from ``rng`` only.
        rng: ``np.random.Generator`` or int seed for the noise.
    """

    #: Steps the plan needs: its last waypoint came at step 278 at most (mean 195) over 500
    #: noisy episodes.
    minimum_episode_len: int = 300

    def plan(self, obs: dict) -> list[Waypoint]:
        """Waypoints from the first observation (see the module doc)."""
        ee0 = np.asarray(obs["ee_pose"], dtype=float)
        cube = np.asarray(obs["env_state"], dtype=float)[:3]
        goal = np.asarray(obs["goal"], dtype=float)[:3]
        free = NOISE_FREE if self.inject_noise else 0.0
        contact = NOISE_CONTACT if self.inject_noise else 0.0

        push = goal[:2] - cube[:2]
        u = push / max(float(np.linalg.norm(push)), 1e-9)  # push direction (xy)
        u3 = np.array([u[0], u[1], 0.0])
        # broad side of the fingers facing the push: the closing axis along the push; of the
        # two such yaws, the one nearer the start's
        yaw = math.atan2(u[1], u[0]) - FACE_YAW
        yaw0 = tool_yaw(ee0[3:])
        yaw = yaw0 + wrap_angle(yaw - yaw0, math.pi)
        quat = tool_down(yaw)

        start = np.array([cube[0], cube[1], PUSH_Z]) - BACK * u3
        hover = self._jitter(start + [0.0, 0.0, HOVER_Z - PUSH_Z], free)
        start = self._jitter(start, contact)
        end = self._jitter(np.array([goal[0], goal[1], PUSH_Z]) - CONTACT * u3, contact)
        lifted = end + [0.0, 0.0, HOVER_Z - PUSH_Z] - 0.02 * u3

        t_hover = max(40, steps_for(np.linalg.norm(hover - ee0[:3]), MOVE_SPEED))
        t_start = t_hover + 30
        t_end = t_start + max(10, steps_for(np.linalg.norm(end - start), PUSH_SPEED))
        t_lift = t_end + 10 + 30
        return [
            waypoint(0, ee0[:3], ee0[3:], 0.0),
            waypoint(t_hover, hover, quat, 0.0),
            waypoint(t_start, start, quat, 0.0),
            waypoint(t_end, end, quat, 0.0),
            waypoint(t_end + 10, end, quat, 0.0),
            waypoint(t_lift, lifted, quat, 0.0),
        ]
