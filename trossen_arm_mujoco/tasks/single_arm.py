"""What the single-arm wxai tasks share: a goal-conditioned task over one arm and gripper,
and a sampler that builds the table scene and perturbs the initial joints.

Frames and units: world frame with the arm base at the origin and the table top at
``table_height`` (m); goals and tool-frame (``ee_site``) positions in m.

Docs: docs/gym/index.md, docs/writing-a-task.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.configs import RobotConfig, wxai_config
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.config_key import Key, number, positive, vector
from trossen_arm_mujoco.tasks.observation import Part
from trossen_arm_mujoco.tasks.sampler import TaskSampler, uniform
from trossen_arm_mujoco.tasks.task import Task

__all__ = [
    "GOAL_REWARD_TYPES",
    "SINGLE_ARM_KEYS",
    "SINGLE_ARM_REQUIRED",
    "SingleArmSampler",
    "SingleArmTask",
    "goal_distance",
]

GOAL_REWARD_TYPES = ("sparse", "dense")


def goal_distance(achieved: np.ndarray, desired: np.ndarray) -> np.ndarray | float:
    """Euclidean distance over the last axis; shapes (..., 3) -> (...); one pair (3,) gives
    a Python float (every step: no arrays, and what follows is plain float arithmetic)."""
    a, d = np.asarray(achieved), np.asarray(desired)
    if a.ndim == 1 and d.ndim == 1:
        return math.dist(a.tolist(), d.tolist())
    return np.linalg.norm(np.subtract(a, d, dtype=float), axis=-1)


_COEF = number(0.0, unit="")  # reward weights: finite, >= 0

#: Config keys of the single-arm tasks (``TaskEntry.keys`` of reach, push, pick_place):
#: the episode start, success and the shaped reward's weights.
SINGLE_ARM_KEYS: dict[str, Key] = {
    "init_arm_qpos": vector(6, low=-math.tau, high=math.tau, unit="rad"),
    "init_joint_noise": number(0.0, 1.0, "rad"),
    "init_gripper": number(0.0, 0.044, "m"),  # finger travel: closed .. open (robot.layout)
    "success_tolerance": positive(1.0, "m"),
    "goal_reward_type": Key("choice", choices=GOAL_REWARD_TYPES),
    "distance_coef": _COEF,
    "success_bonus": _COEF,
    "reach_coef": _COEF,
}
#: Of those, the keys every single-arm task's config must hold.
SINGLE_ARM_REQUIRED: tuple[str, ...] = ("init_arm_qpos", "success_tolerance", "goal_reward_type")


class SingleArmTask(Task):
    """A wxai task scored by the distance of an achieved goal to a desired goal (m).

    Its observation starts with the robot's parts (``robot_parts``); a task adds its own
    parts after them and names the part that is its achieved goal (``achieved_part``). The
    desired goal is ``goal`` (a part named ``"goal"``, bounded by the workspace).

    Args:
        scene, config: see ``Task``; also reads ``success_tolerance``, ``goal_reward_type``,
            ``workspace_low/high``, ``max_joint_velocity``.
        goal: desired goal, world frame (3,) m; defaults to the workspace centre.
    """

    robot_name: ClassVar[str] = "wxai"
    goal_conditioned: ClassVar[bool] = True
    #: mocap body showing the goal in the scene.
    marker_body: ClassVar[str] = ""
    #: the observation part that is the achieved goal (3,) m, world frame.
    achieved_part: ClassVar[str] = ""

    def __init__(self, scene: Scene, config: Mapping[str, Any], goal: Any = None):
        super().__init__(scene, config)
        view = self.robot.view
        self.arm = view.get_move_group("arm")
        self.gripper = view.get_move_group("gripper")
        self.tolerance = float(self.config["success_tolerance"])
        self.reward_type = str(self.config["goal_reward_type"])
        if self.reward_type not in GOAL_REWARD_TYPES:
            raise unknown_name_error("goal reward type", self.reward_type, GOAL_REWARD_TYPES)
        self.ws_low = np.asarray(self.config["workspace_low"], dtype=float)
        self.ws_high = np.asarray(self.config["workspace_high"], dtype=float)
        self.max_qvel = float(self.config["max_joint_velocity"])
        # reward coefficients of the dense rewards, read once (0 where a task has none)
        self.distance_coef = float(self.config.get("distance_coef", 0.0))
        self.success_bonus = float(self.config.get("success_bonus", 0.0))
        centre = 0.5 * (self.ws_low + self.ws_high)
        self._goal = centre if goal is None else np.asarray(goal, dtype=float).reshape(3).copy()
        self._mocap = int(
            scene.model.body_mocapid[lookup_id(scene.model, "body", self.marker_body)]
        )

    @property
    def goal(self) -> np.ndarray:
        """Desired goal (3,) m, world frame: the array the ``goal`` part views (assigning
        copies into it, so the part follows)."""
        return self._goal

    @goal.setter
    def goal(self, value: Any) -> None:
        self._goal[:] = np.asarray(value, dtype=float).reshape(3)

    # -- physics hooks --------------------------------------------------------------------
    def initialize_episode(self) -> None:
        """Show the goal: move the marker's mocap body there."""
        self.data.mocap_pos[self._mocap] = self.goal

    # -- observation ------------------------------------------------------------------------
    def robot_parts(self) -> list[Part]:
        """The robot's observation parts, live views of ``data``: ``arm_qpos`` (6,) rad,
        ``arm_qvel`` (6,) rad/s, ``gripper`` (1,) finger travel m, ``ee_pos`` (3,) m (tool
        frame, world)."""
        data = self.data
        arm, gripper = self.arm, self.gripper
        joints = arm.state_views(data)
        if joints is None:  # joints not consecutive in qpos/qvel: read them each time
            joints = (lambda: arm.get_qpos(data)), (lambda: arm.get_qvel(data))
        lo, hi = gripper.ctrl_limits.T
        return [
            Part("arm_qpos", joints[0], arm.joint_range[:, 0], arm.joint_range[:, 1]),
            Part("arm_qvel", joints[1], -self.max_qvel, self.max_qvel),
            Part("gripper", gripper.noop_ctrl_view(data), lo, hi),
            Part("ee_pos", arm.frame_position_view(data), self.ws_low, self.ws_high),
        ]

    def observation_parts(self) -> list[Part]:
        """The robot's parts (``robot_parts``); tasks with objects add theirs."""
        return self.robot_parts()

    def goal_parts(self) -> tuple[Part, Part]:
        """(the ``achieved_part`` observation part, ``goal``), both in the workspace box."""
        goal = Part("goal", self._goal, self.ws_low, self.ws_high)
        return self.observed[self.achieved_part], goal

    def ee_pos(self) -> np.ndarray:
        """Tool-frame (ee_site) position, world frame (3,) m (a copy)."""
        return self.observed.read("ee_pos").copy()

    # -- goals ----------------------------------------------------------------------------
    def goal_success(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """Within ``success_tolerance``; shapes (..., 3) -> bool (...)."""
        return goal_distance(achieved, desired) < self.tolerance

    def goal_reward(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """``sparse``: -1 outside the tolerance, 0 inside; ``dense``: -distance (m).
        Shapes (..., 3) -> float (...)."""
        return self.goal_reward_at(goal_distance(achieved, desired))

    def goal_reward_at(self, dist: np.ndarray) -> np.ndarray:
        """``goal_reward`` of goals ``dist`` (m; a float or an array) apart."""
        if self.reward_type == "sparse":
            return (dist < self.tolerance) - 1.0  # 0 within the tolerance, else -1
        return -dist

    def judge_success(self) -> bool:
        """Whether the goal distance (m) is below the config's ``success_tolerance``."""
        return self.distance() < self.tolerance

    # -- scoring: the reward and the diagnostics from one goal distance --------------------
    #: the distance of the state being scored, while ``score`` runs (None otherwise)
    _distance_now: float | None = None

    def distance(self) -> float:
        """Distance (m) of the achieved goal to the desired goal (read from the goal parts,
        no copies); inside ``score``, the one distance of the state scored."""
        dist = self._distance_now
        if dist is not None:
            return dist
        achieved, desired = self.goals
        return goal_distance(achieved.read(), desired.read())

    def score(self) -> tuple[float, dict[str, Any]]:
        """``Task.score`` with the goal distance computed once: ``get_reward``,
        ``get_info`` (and anything they call) see the same ``distance()``."""
        self._distance_now = self.distance()
        try:
            return super().score()
        finally:
            self._distance_now = None

    def reward_at(self, dist: float) -> float:
        """The task's dense reward, the achieved goal being ``dist`` (m) from the desired
        one (the non-goal env's reward)."""
        raise NotImplementedError

    def info_at(self, dist: float) -> dict[str, Any]:
        """``get_info`` with the achieved goal ``dist`` (m) from the desired one:
        ``is_success`` and ``goal_distance`` (m)."""
        return {"is_success": dist < self.tolerance, "goal_distance": dist}

    def get_reward(self) -> float:
        """The reward at the current goal distance (``reward_at``: sparse or dense)."""
        return self.reward_at(self.distance())

    def get_info(self) -> dict[str, Any]:
        return self.info_at(self.distance())


class SingleArmSampler(TaskSampler):
    """Builds a wxai table scene; the arm starts at ``init_arm_qpos`` (rad) plus uniform
    noise of ``init_joint_noise`` (rad), the gripper at ``init_gripper`` (m, default open)."""

    robot_name: ClassVar[str] = "wxai"
    arms: ClassVar[tuple[tuple[str, str], ...]] = (("arm", "gripper"),)
    cameras: ClassVar[tuple[str, ...]] = ("overview", "cam")

    def robot_config(self) -> RobotConfig:
        """The wxai robot starting at the config's ``init_arm_qpos`` (rad) with the
        fingers at ``init_gripper`` (m, default open)."""
        base = wxai_config()
        fingers = float(self.config.get("init_gripper", GRIPPER_OPEN))
        init = {"arm": list(self.config["init_arm_qpos"]), "gripper": [fingers, fingers]}
        return RobotConfig(base.name, base.groups, init, base.command_mode)

    def perturb_arm(self, rng: np.random.Generator) -> None:
        """Add the initial joint noise to the arm (in place, within the joint limits)."""
        noise = float(self.config.get("init_joint_noise", 0.0))
        arm = self.scene.robots[self.robot_name].view.get_move_group("arm")
        q = arm.get_qpos(self.scene.data) + uniform(rng, -noise, noise, arm.n_joints)
        arm.set_qpos(self.scene.data, clip(q, arm.joint_range[:, 0], arm.joint_range[:, 1]))
