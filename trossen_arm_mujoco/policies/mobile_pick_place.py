"""The scripted policy of ``mobile_pick_place``: the base drives to the table, then the left
arm picks the cube and places it on the target.

It acts in the Mobile AI's 16 values (``robot.layout.MOBILEAI_LAYOUT``: the arms' 14 joint
targets, then the base's [x.vel m/s, theta.vel rad/s]), as a policy trained on
``mobileai_robot`` data does; it is closed-loop on the observation and plans the arm with
the robot's IK on the kinematics' own ``MjData`` (it computes, the env steps). Plan (steps of
``policy_dt``, 0.02 s): drive until the left shoulder is ``REACH`` m short of the cube, stop;
then arm segments, each moving the joint targets linearly to its IK solution: above the
cube, down, close, lift, above the target, down, open, up.

Docs: docs/concepts/models.md (The mobile pick-and-place task).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN, KIT14_LAYOUT, MOBILEAI_LAYOUT

__all__ = ["DOWN", "GRASP", "SEGMENTS", "MobilePickPlacePolicy", "planar_pose"]

#: The tool frame pointing down (its x axis, the fingers' direction, along world -z), wxyz.
DOWN = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])
#: Finger travel commanded on the 50 mm cube (m; the pads stop at 25 mm, the rest squeezes).
GRASP = 0.015
#: Half the cube's edge (m): its centre rests this far above the table.
CUBE_HALF = 0.025
#: The left shoulder stops this far (m, along x) short of the cube.
REACH = 0.27
#: Arm segments: (name, steps, height of the tool above the cube's centre (m), now or as
#: placed on the target, which of the two, gripper). The first ~70 % of each segment
#: moves, the rest holds.
SEGMENTS: tuple[tuple[str, int, float, str, float], ...] = (
    ("above_cube", 90, 0.12, "cube", GRIPPER_OPEN),
    ("down", 60, 0.005, "cube", GRIPPER_OPEN),
    ("close", 40, 0.005, "cube", GRASP),
    ("lift", 60, 0.15, "cube", GRASP),
    ("above_target", 80, 0.15, "target", GRASP),
    ("lower", 60, 0.01, "target", GRASP),
    ("open", 35, 0.01, "target", GRIPPER_OPEN),
    ("up", 40, 0.15, "target", GRIPPER_OPEN),
)
#: Most steps the drive may take, and the steps the base then rests before the arm moves.
MAX_DRIVE_STEPS, SETTLE_STEPS = 250, 20


def planar_pose(pose7: np.ndarray) -> tuple[float, float, float]:
    """(x m, y m, yaw rad) of a base pose [xyz m, quat wxyz] (yaw about world z)."""
    x, y, _, w, qx, qy, qz = (float(v) for v in pose7)
    return x, y, float(np.arctan2(2 * (w * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))


class MobilePickPlacePolicy:
    """Drive, pick, place (module docstring).

    Args:
        task: the episode's ``MobilePickPlaceTask`` (its robot's IK and its shoulder body).
        inject_noise: jitter the grasp and place points (up to 5 mm).
        rng: source of that noise.

    ``policy(observation) -> (16,)`` action in the ``mobileai`` layout; ``minimum_episode_len``
    is the most steps it needs.
    """

    #: the layout of its actions (``robot.layout.LAYOUTS``): a joint policy, recorded as it
    #: acts (an end-effector policy has none, or ``"ee"``)
    action_layout: str = "mobileai"
    minimum_episode_len: int = MAX_DRIVE_STEPS + SETTLE_STEPS + sum(s[1] for s in SEGMENTS)

    def __init__(
        self, task: Any, inject_noise: bool = False, rng: np.random.Generator | int | None = None
    ):
        self.task = task
        self.robot = task.robot
        self.inject_noise = bool(inject_noise)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.arm = self.robot.view.get_move_group("left_arm")
        self.shoulder_ahead: float | None = None
        self.step = 0
        self.phase = "drive"
        self.parked_at = 0
        self.arm_start = 0
        self.hold: np.ndarray | None = None  # the arms' targets until the arm moves (16,)
        self.targets: list[np.ndarray] = []  # per arm step: 16 values

    def _x_goal(self, obs: dict[str, np.ndarray]) -> float:
        """Base x at which the left shoulder is ``REACH`` short of the cube."""
        if self.shoulder_ahead is None:
            x, y, yaw = planar_pose(obs["base_pose"])
            offset = self.task.data.xpos[self.task.shoulder][:2] - [x, y]
            # the shoulder's offset ahead of the base origin along its heading
            self.shoulder_ahead = float(offset @ [np.cos(yaw), np.sin(yaw)])
        return float(obs["env_state"][0] - REACH - self.shoulder_ahead)

    def _plan_arm(self, obs: dict[str, np.ndarray]) -> None:
        """Joint targets of every arm step, from the parked base's IK."""
        noise = 0.005 if self.inject_noise else 0.0
        jitter = self.rng.uniform(-noise, noise, (2, 3)) * [1.0, 1.0, 0.0]
        # cube centre now, and where it rests on the target
        points = {
            "cube": np.asarray(obs["env_state"][:3], dtype=float) + jitter[0],
            "target": np.asarray(obs["target"], dtype=float) + [0.0, 0.0, CUBE_HALF] + jitter[1],
        }
        left, grip = MOBILEAI_LAYOUT.arm("left"), MOBILEAI_LAYOUT.gripper_index("left")
        prev = self.hold.copy()
        q_prev = prev[left]
        for name, steps, height, which, gripper in SEGMENTS:
            pose = np.concatenate([points[which] + [0.0, 0.0, height], DOWN])
            ik = self.robot.kinematics.solve_ik("left_arm", pose, q0={"left_arm": q_prev})
            if not ik.converged:
                raise UserError(
                    f"mobile_pick_place policy: no IK solution for segment '{name}' "
                    f"(tool at {np.round(pose[:3], 3).tolist()} m); the cube is out of reach"
                )
            q_prev = np.asarray(ik.qpos["left_arm"], dtype=float)
            goal = prev.copy()
            goal[left], goal[grip] = q_prev, gripper
            moving = max(1, int(0.7 * steps))
            for k in range(steps):
                self.targets.append(prev + min(1.0, (k + 1) / moving) * (goal - prev))
            prev = goal

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """The (16,) action of this step (``mobileai`` layout)."""
        t, self.step = self.step, self.step + 1
        if self.hold is None:
            arms = np.asarray(obs["qpos"], dtype=float)[KIT14_LAYOUT.vendor_index]
            self.hold = np.concatenate([arms, [0.0, 0.0]])
        if self.phase == "drive":
            x, _, yaw = planar_pose(obs["base_pose"])
            left = self._x_goal(obs) - x
            speed = float(np.abs(obs["base_vel"]).max())
            if (abs(left) < 0.004 and speed < 0.01) or t >= MAX_DRIVE_STEPS:
                self.phase, self.parked_at = "settle", t
            else:
                v = float(np.clip(3.0 * left, -0.5, 0.5))
                w = float(np.clip(-3.0 * yaw, -0.5, 0.5))
                return np.concatenate([self.hold[:14], [v, w]])
        if self.phase == "settle":
            if t - self.parked_at < SETTLE_STEPS:
                return self.hold.copy()
            self._plan_arm(obs)
            self.phase, self.arm_start = "arm", t
        k = min(t - self.arm_start, len(self.targets) - 1)
        return self.targets[k].copy()
