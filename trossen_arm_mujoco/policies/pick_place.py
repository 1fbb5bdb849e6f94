"""Scripted pick and place for the single wxai arm (task ``pick_place``).

``PickPlacePolicy(inject_noise=False, rng=None)`` is called with the policy observation of
``collect.single_arm`` (``ee_pose``, ``env_state`` = the cube pose, ``goal``) and returns the
8-value EE action ``[xyz (m), quat wxyz, gripper (m)]`` of the tool frame in the world frame.

The plan (world frame, steps of 0.02 s), built once from the first observation: the open
gripper, pointing down and turned to the cube's faces (its yaw modulo 90 deg, nearest the
arm's heading to the cube), goes ``APPROACH`` above the cube, descends until the fingertips
are ``GRASP_DEPTH`` below the cube's centre, closes, lifts, carries the cube above the goal
and lowers it until the cube's centre is on the goal. A goal resting on the table: the
gripper opens and rises; a goal in the air: the gripper holds the cube there.

Docs: docs/gym/WXAIPickPlace-v0.md, docs/cli/record.md (Single-arm tasks).
"""

from __future__ import annotations

import math

import numpy as np

from trossen_arm_mujoco.policies.push import tool_down, tool_yaw, wrap_angle
from trossen_arm_mujoco.policies.scripted import (
    GRIPPER_PLAN_SPEED,
    ArmWaypointPolicy,
    Waypoint,
    steps_for,
    waypoint,
)
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN

__all__ = [
    "ABOVE_GOAL",
    "APPROACH",
    "GRASP_DEPTH",
    "GRIPPER_GRASP",
    "GRIPPER_STEPS",
    "PickPlacePolicy",
]

#: Finger travel commanded to grasp the 40 mm cube: the pads stop at about 20 mm; the
#: difference sets the squeeze (kp 1000 N/m: about 8 N).
GRIPPER_GRASP = 0.012
#: Steps to move the fingers between open and grasp at the planned gripper speed (23).
GRIPPER_STEPS = steps_for(GRIPPER_OPEN - GRIPPER_GRASP, GRIPPER_PLAN_SPEED)
#: Height of the tool frame above the cube's centre before descending, and when carrying (m).
APPROACH = 0.08
#: Height of the tool frame above a goal in the air before lowering the cube onto it (m).
ABOVE_GOAL = 0.02
#: The fingertips (tool frame) this far below the cube's centre when grasping (m).
GRASP_DEPTH = 0.01
#: A goal this close (m) above the cube's resting height counts as on the table.
ON_TABLE = 0.005
#: Tool speed moving freely (m/s).
MOVE_SPEED = 0.2
#: Noise scales (m): free-space waypoints, and waypoints at the cube.
NOISE_FREE = 0.01
NOISE_CONTACT = 0.002


class PickPlacePolicy(ArmWaypointPolicy):
    """Pick the cube and bring it to the goal (module docstring).

    Args:
        inject_noise: perturb waypoint positions (uniform, up to 1 cm in free space and
            2 mm at the cube), drawn from ``rng`` only.
        rng: ``np.random.Generator`` or int seed for the noise.
    """

    #: Steps the plan needs: its last waypoint came at step 297 at most (mean 237) over 500
    #: noisy episodes (a far goal on the table, then open and rise).
    minimum_episode_len: int = 320

    def plan(self, obs: dict) -> list[Waypoint]:
        """Waypoints from the first observation (see the module doc)."""
        ee0 = np.asarray(obs["ee_pose"], dtype=float)
        cube_pose = np.asarray(obs["env_state"], dtype=float)[:7]
        cube = cube_pose[:3]
        goal = np.asarray(obs["goal"], dtype=float)[:3]
        free = NOISE_FREE if self.inject_noise else 0.0
        contact = NOISE_CONTACT if self.inject_noise else 0.0

        # The fingers close along a face normal of the cube: yaw = cube yaw modulo 90 deg,
        # the one nearest the arm's heading toward the cube (least wrist roll).
        w, _, _, z = cube_pose[3:]
        cube_yaw = 2.0 * math.atan2(z, w)
        heading = math.atan2(cube[1], cube[0]) + wrap_angle(tool_yaw(ee0[3:]), math.pi)
        yaw = heading + wrap_angle(cube_yaw - heading, math.pi / 2)
        quat = tool_down(yaw)

        grasp = self._jitter(cube - [0.0, 0.0, GRASP_DEPTH], contact)
        above = self._jitter(grasp + [0.0, 0.0, APPROACH], free)
        lifted = grasp + [0.0, 0.0, APPROACH]
        place = self._jitter(goal - [0.0, 0.0, GRASP_DEPTH], contact)
        # carried at the lifted height, or just above a goal in the air: pointing down, the
        # wrist (joint_3) runs out of range higher up (the IK then left the path at 0.21 m)
        carry_z = max(lifted[2], place[2] + ABOVE_GOAL)
        over_goal = self._jitter(np.array([place[0], place[1], carry_z]), free)
        on_table = goal[2] <= cube[2] + ON_TABLE

        o, c, g = GRIPPER_OPEN, GRIPPER_GRASP, GRIPPER_STEPS
        t_above = max(40, steps_for(np.linalg.norm(above - ee0[:3]), MOVE_SPEED))
        t_grasp = t_above + 35
        t_closed = t_grasp + g + 5
        t_lifted = t_closed + 30
        t_over = t_lifted + max(30, steps_for(np.linalg.norm(over_goal - lifted), MOVE_SPEED))
        t_place = t_over + 35
        plan = [
            waypoint(0, ee0[:3], ee0[3:], o),
            waypoint(t_above, above, quat, o),
            waypoint(t_grasp, grasp, quat, o),
            waypoint(t_grasp + g, grasp, quat, c),
            waypoint(t_closed, grasp, quat, c),
            waypoint(t_lifted, lifted, quat, c),
            waypoint(t_over, over_goal, quat, c),
            waypoint(t_place, place, quat, c),
        ]
        if on_table:  # let go and rise
            plan += [
                waypoint(t_place + 5, place, quat, c),
                waypoint(t_place + 5 + g, place, quat, o),
                waypoint(t_place + 5 + g + 30, place + [0.0, 0.0, APPROACH], quat, o),
            ]
        return plan
