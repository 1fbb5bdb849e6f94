"""Scripted bimanual peg insertion for the end-effector (mocap) env.

``InsertionPolicy(inject_noise=False, rng=None)`` is called with a time step whose
``observation`` has ``mocap_pose_left``, ``mocap_pose_right`` (tool-frame poses [xyz m, quat
wxyz]) and ``env_state`` (14: peg pose then socket pose) and returns the 16-value EE action
``[left xyz, left quat wxyz, left gripper, right xyz, right quat, right gripper]`` (world
frame, m). On the first call it builds ``left_trajectory`` and ``right_trajectory``
(``generate_trajectory``): the grippers, pointing down and tilted back by ``TILT_DEG``,
grasp the socket (left) and the peg (right) from above, lift them onto one line along y
(the socket at ``MEET_POINT``), and the right arm slides the peg in until it presses on the
pin.

Docs: docs/gym/StationaryAIInsertion-v0.md; the plan: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from trossen_arm_mujoco.policies.scripted import (
    GRIPPER_PLAN_SPEED,
    BimanualWaypointPolicy,
    Waypoint,
    steps_for,
    waypoint,
)
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN
from trossen_arm_mujoco.tasks.insertion import PEG_HALF, PIN_FACE_Y, SOCKET_MOUTH_Y

__all__ = [
    "APPROACH",
    "GRIPPER_SPEED",
    "LIFT",
    "MEET_POINT",
    "NOISE_CONTACT",
    "NOISE_FREE",
    "OVERTRAVEL",
    "PEG_GRASP",
    "PEG_GRIP",
    "PEG_SAG",
    "PRE_INSERT_GAP",
    "SOCKET_GRASP",
    "SOCKET_GRIP",
    "TILT_DEG",
    "InsertionPolicy",
]

GRIPPER_SPEED = GRIPPER_PLAN_SPEED
#: Finger travel commanded on the 20 mm peg and on the 32 mm socket: the pads would meet
#: about 4.5 mm inside each face; the difference sets the squeeze of the position actuator
#: (as on the 25 mm cube of the transfer).
PEG_GRASP = 0.0055
SOCKET_GRASP = 0.0115
#: Lean of both grippers from pointing straight down, back toward their own arm (deg).
TILT_DEG = 45.0
#: Tool-frame (fingertip) grasp points relative to the object centres (m, world): right on
#: the peg 15 mm behind its centre (-y), left on the socket 8 mm toward its closed end (+y).
#: Both at z = 0.031: the leaning fingertips reach 6.2 mm below the tool frame, so they stay
#: about 5 mm above the table (3 mm with noise).
PEG_GRIP = np.array([0.0, -0.015, 0.001])
SOCKET_GRIP = np.array([0.0, 0.008, -0.005])
#: Where the socket's centre is carried (world, m); the peg comes in along +y.
MEET_POINT = np.array([0.02, 0.06, 0.16])
#: Peg tip before the mouth when lining up, and past the pin's face at the end (m).
PRE_INSERT_GAP = 0.015
OVERTRAVEL = 0.004
#: The peg tilts slightly in the grasp under its weight: its tip sits about 0.9 mm below
#: the line through the grasp (measured in the joint replay), so the right hand carries it
#: this much higher when lining up (m).
PEG_SAG = 0.001
#: Distances backed off along the finger axis above the grasp, and lifted (m).
APPROACH = 0.06
LIFT = 0.08
#: Noise scales (m): free-space waypoints, and waypoints that touch an object.
NOISE_FREE = 0.01
NOISE_CONTACT = 0.002


class InsertionPolicy(BimanualWaypointPolicy):
    """Scripted peg insertion: left arm socket, right arm peg, meet and insert.

    Args:
        inject_noise: perturb waypoint positions (uniform, up to 1 cm in free space and
            2 mm at the grasps), drawn from ``rng`` only.
        rng: ``np.random.Generator`` or int seed for the noise.
    """

    #: Steps (0.02 s) the plan needs: the peg reaches the pin at step 366, then both hold.
    minimum_episode_len: ClassVar[int] = 400

    # Waypoint times (steps); the gripper closes at GRIPPER_SPEED.
    T_ABOVE = 90
    T_GRASP = 120
    T_CLOSED = T_GRASP + max(
        steps_for(GRIPPER_OPEN - PEG_GRASP, GRIPPER_SPEED),
        steps_for(GRIPPER_OPEN - SOCKET_GRASP, GRIPPER_SPEED),
    )
    T_LIFT_START = T_CLOSED + 8
    T_LIFTED = T_LIFT_START + 40
    T_ALIGNED = T_LIFTED + 70
    T_INSERT_START = T_ALIGNED + 20
    T_INSERTED = T_INSERT_START + 80

    @staticmethod
    def grasp_quat(start_quat: np.ndarray) -> np.ndarray:
        """Tool orientation for the grasps: the start frame (pointing at the table centre,
        fingers opening along world x) pitched down about its own y axis, leaning back
        ``TILT_DEG`` from vertical."""
        return (Quaternion(start_quat) * Quaternion(axis=[0, 1, 0], degrees=90 - TILT_DEG)).elements

    def plan(self, obs: dict) -> tuple[list[Waypoint], list[Waypoint]]:
        """(left, right) waypoints from the first observation (see the module doc)."""
        left0 = np.asarray(obs["mocap_pose_left"], dtype=float)
        right0 = np.asarray(obs["mocap_pose_right"], dtype=float)
        state = np.asarray(obs["env_state"], dtype=float)
        peg, socket = state[0:3], state[7:10]

        free = NOISE_FREE if self.inject_noise else 0.0
        contact = NOISE_CONTACT if self.inject_noise else 0.0
        left_q, right_q = self.grasp_quat(left0[3:]), self.grasp_quat(right0[3:])
        left_axis = Quaternion(left_q).rotate([1.0, 0.0, 0.0])  # finger direction, world
        right_axis = Quaternion(right_q).rotate([1.0, 0.0, 0.0])

        # Grasps: fingertips around each object; the approach comes down the finger axis.
        socket_grasp = self._jitter(socket + SOCKET_GRIP, contact)
        peg_grasp = self._jitter(peg + PEG_GRIP, contact)
        socket_above = self._jitter(socket_grasp - APPROACH * left_axis, free)
        peg_above = self._jitter(peg_grasp - APPROACH * right_axis, free)
        socket_lifted = self._jitter(socket_grasp + [0.0, 0.0, LIFT], free)
        peg_lifted = self._jitter(peg_grasp + [0.0, 0.0, LIFT], free)

        # Object offsets in the hand: the closing fingers centre the object across them (x);
        # along y and z it stays where the fingertips met it.
        socket_in_hand = socket - socket_grasp
        socket_in_hand[0] = 0.0
        peg_in_hand = peg - peg_grasp
        peg_in_hand[0] = 0.0

        meet = self._jitter(MEET_POINT, free)  # socket centre; the peg lines up with it
        left_meet = meet - socket_in_hand
        peg_tip = PEG_HALF[1]  # peg centre -> tip, along +y
        peg_pre = meet + [0.0, SOCKET_MOUTH_Y - PRE_INSERT_GAP - peg_tip, PEG_SAG]
        peg_in = meet + [0.0, PIN_FACE_Y + OVERTRAVEL - peg_tip, PEG_SAG]
        right_pre = peg_pre - peg_in_hand
        right_in = peg_in - peg_in_hand

        o = GRIPPER_OPEN
        ps, ss = PEG_GRASP, SOCKET_GRASP
        left = [
            waypoint(0, left0[:3], left0[3:], o),
            waypoint(self.T_ABOVE, socket_above, left_q, o),
            waypoint(self.T_GRASP, socket_grasp, left_q, o),
            waypoint(self.T_GRASP + steps_for(o - ss, GRIPPER_SPEED), socket_grasp, left_q, ss),
            waypoint(self.T_LIFT_START, socket_grasp, left_q, ss),
            waypoint(self.T_LIFTED, socket_lifted, left_q, ss),
            waypoint(self.T_ALIGNED, left_meet, left_q, ss),
            waypoint(self.minimum_episode_len, left_meet, left_q, ss),
        ]
        right = [
            waypoint(0, right0[:3], right0[3:], o),
            waypoint(self.T_ABOVE, peg_above, right_q, o),
            waypoint(self.T_GRASP, peg_grasp, right_q, o),
            waypoint(self.T_GRASP + steps_for(o - ps, GRIPPER_SPEED), peg_grasp, right_q, ps),
            waypoint(self.T_LIFT_START, peg_grasp, right_q, ps),
            waypoint(self.T_LIFTED, peg_lifted, right_q, ps),
            waypoint(self.T_ALIGNED, right_pre, right_q, ps),
            waypoint(self.T_INSERT_START, right_pre, right_q, ps),
            waypoint(self.T_INSERTED, right_in, right_q, ps),
            waypoint(self.minimum_episode_len, right_in, right_q, ps),
        ]
        return left, right
