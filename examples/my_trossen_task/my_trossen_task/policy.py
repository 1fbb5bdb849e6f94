"""The scripted policy of ``lift_puck``: the right gripper turns to point down, descends
onto the puck, closes on it and lifts it 13 cm; the left arm stays home.

Waypoints are in the world frame, one step = 0.02 s; the plan ends at step 230.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.policies.scripted import BimanualWaypointPolicy, waypoint
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN

#: Finger travel commanded to grasp the 30 mm puck (the pads stop at 15 mm; the rest
#: squeezes).
GRIPPER_GRASP = 0.004
LIFT = 0.13


class LiftPuckPolicy(BimanualWaypointPolicy):
    """Right arm: above the puck, down, close, lift; left arm: hold its start pose."""

    minimum_episode_len: int = 230

    def plan(self, obs: dict) -> tuple[list, list]:
        left0 = np.asarray(obs["mocap_pose_left"], dtype=float)
        right0 = np.asarray(obs["mocap_pose_right"], dtype=float)
        puck = np.asarray(obs["env_state"], dtype=float)[:3]
        noise = 0.005 if self.inject_noise else 0.0
        down = (Quaternion(right0[3:]) * Quaternion(axis=[0, 1, 0], degrees=90)).elements
        grasp = self._jitter(puck + [0.0, 0.0, 0.002], noise / 2)
        above = self._jitter(grasp + [0.0, 0.0, 0.08], noise)
        lifted = grasp + [0.0, 0.0, LIFT]
        o, c = GRIPPER_OPEN, GRIPPER_GRASP
        right = [
            waypoint(0, right0[:3], right0[3:], o),
            waypoint(90, above, down, o),
            waypoint(130, grasp, down, o),
            waypoint(160, grasp, down, c),
            waypoint(170, grasp, down, c),
            waypoint(230, lifted, down, c),
            waypoint(10_000, lifted, down, c),
        ]
        left = [waypoint(0, left0[:3], left0[3:], o), waypoint(10_000, left0[:3], left0[3:], o)]
        return left, right
