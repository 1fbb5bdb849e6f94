"""What the single-arm wxai tasks share: a goal-conditioned task over one arm and gripper,
and a sampler that builds the table scene and perturbs the initial joints.

Frames and units: world frame with the arm base at the origin and the table top at
``table_height`` (m); goals and tool-frame (``ee_site``) positions in m.
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
from trossen_arm_mujoco.sim.env import MujocoEnv
from trossen_arm_mujoco.tasks.sampler import TaskSampler, uniform
from trossen_arm_mujoco.tasks.task import Bounds, Task, trusts_shortcut

GOAL_REWARD_TYPES = ("sparse", "dense")
#: the shortcuts that make up ``SingleArmTask.state_parts`` (and ``distance``)
STATE_SHORTCUTS = ("_robot_parts", "_object_parts", "_achieved_view", "_desired_view")


def goal_distance(achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """Euclidean distance over the last axis; shapes (..., 3) -> (...)."""
    a, d = np.asarray(achieved), np.asarray(desired)
    if a.ndim == 1 and d.ndim == 1:  # one pair, every step: Python floats, no arrays
        return np.float64(math.dist(a.tolist(), d.tolist()))
    return np.linalg.norm(np.subtract(a, d, dtype=float), axis=-1)


class SingleArmTask(Task):
    """A wxai task scored by the distance of an achieved goal to a desired goal (m).

    Args:
        env, config: see ``Task``; also reads ``success_tolerance``, ``goal_reward_type``,
            ``workspace_low/high``, ``max_joint_velocity``.
        goal: desired goal, world frame (3,) m; defaults to the workspace centre.
    """

    robot_name: ClassVar[str] = "wxai"
    goal_conditioned: ClassVar[bool] = True
    #: mocap body showing the goal in the scene.
    marker_body: ClassVar[str] = ""

    def __init__(self, env: MujocoEnv, config: Mapping[str, Any], goal: Any = None):
        super().__init__(env, config)
        view = self.robot.view
        self.arm = view.group("arm")
        self.gripper = view.group("gripper")
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
        self.goal = centre if goal is None else np.asarray(goal, dtype=float).reshape(3).copy()
        self._mocap = int(env.model.body_mocapid[lookup_id(env.model, "body", self.marker_body)])
        # live views of the robot state (robot_observation order) and of the tool frame, read
        # by the shortcuts of the gym env's state vector (None: the joints are not consecutive)
        data = env.data
        joints = self.arm.state_views(data)
        self._ee_view = self.arm.frame_position_view(data)
        self._robot_views = None if joints is None else [
            *joints, self.gripper.noop_ctrl_view(data), self._ee_view
        ]  # fmt: skip
        self._fast_state = self._robot_views is not None and all(
            trusts_shortcut(type(self), name) for name in STATE_SHORTCUTS
        )

    # -- physics hooks --------------------------------------------------------------------
    def initialize_episode(self) -> None:
        """Show the goal: move the marker's mocap body there."""
        self.data.mocap_pos[self._mocap] = self.goal

    # -- robot state ----------------------------------------------------------------------
    def ee_pos(self) -> np.ndarray:
        """Tool-frame (ee_site) position, world frame (3,) m."""
        return self.arm.get_frame_position(self.data)

    def robot_observation(self) -> dict[str, np.ndarray]:
        """arm_qpos (6,) rad, arm_qvel (6,) rad/s, gripper (1,) finger travel m, ee_pos (3,)."""
        return {
            "arm_qpos": self.arm.get_qpos(self.data),
            "arm_qvel": self.arm.get_qvel(self.data),
            "gripper": self.gripper.get_noop_ctrl(self.data),
            "ee_pos": self.ee_pos(),
        }

    def robot_bounds(self) -> Bounds:
        lo, hi = self.gripper.ctrl_limits()
        return {
            "arm_qpos": (self.arm.joint_range[:, 0].copy(), self.arm.joint_range[:, 1].copy()),
            "arm_qvel": (np.full(6, -self.max_qvel), np.full(6, self.max_qvel)),
            "gripper": (lo, hi),
            "ee_pos": (self.ws_low.copy(), self.ws_high.copy()),
        }

    # -- shortcuts of the gym env's state vector (see ``Task.state_parts``) ---------------
    _shortcuts = {
        "_score": ("get_reward", "get_info"),
        "_robot_parts": ("robot_observation", "ee_pos"),
        "_desired_view": ("desired_goal",),
        "_goal_score": ("goal_reward", "goal_success"),
    }

    def _robot_parts(self) -> list[np.ndarray]:
        """``robot_observation``'s values as live views."""
        return self._robot_views

    def _object_parts(self) -> list[np.ndarray]:
        """The values ``get_observation`` adds to ``robot_observation``, in its order (live
        views where they can be); each task defines it next to its ``get_observation``."""
        raise NotImplementedError

    def _achieved_view(self) -> np.ndarray:
        """``achieved_goal`` as a live view; each task defines it next to its
        ``achieved_goal``."""
        raise NotImplementedError

    def _desired_view(self) -> np.ndarray:
        return self.goal

    def state_parts(self, with_goal: bool = False) -> list[np.ndarray] | None:
        if not self._fast_state:
            return None
        parts = [*self._robot_views, *self._object_parts()]
        if with_goal:
            desired = self._desired_view()
            parts += (desired, desired - self._achieved_view())
        return parts

    def goal_views(self) -> tuple[np.ndarray, np.ndarray] | None:
        if not self._fast_state:
            return None
        return self._achieved_view(), self._desired_view()

    # -- goals ----------------------------------------------------------------------------
    def desired_goal(self) -> np.ndarray:
        return self.goal.copy()

    def goal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of achieved and desired goals: the workspace box (m)."""
        return self.ws_low.copy(), self.ws_high.copy()

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

    def _goal_score(self, achieved: np.ndarray, desired: np.ndarray) -> tuple[float, bool]:
        dist = float(goal_distance(achieved, desired))
        return float(self.goal_reward_at(dist)), dist < self.tolerance

    def judge_success(self) -> bool:
        return bool(self.goal_success(self.achieved_goal(), self.desired_goal()))

    # -- scoring: the reward and the diagnostics from one goal distance --------------------
    def distance(self) -> float:
        """Distance (m) of the achieved goal to the desired goal."""
        if self._fast_state:
            return float(goal_distance(self._achieved_view(), self._desired_view()))
        return float(goal_distance(self.achieved_goal(), self.desired_goal()))

    def reward_at(self, dist: float) -> float:
        """The task's dense reward, the achieved goal being ``dist`` (m) from the desired
        one (the non-goal env's reward)."""
        raise NotImplementedError

    def info_at(self, dist: float) -> dict[str, Any]:
        """``get_info`` with the achieved goal ``dist`` (m) from the desired one:
        ``is_success`` and ``goal_distance`` (m)."""
        return {"is_success": dist < self.tolerance, "goal_distance": dist}

    def get_reward(self) -> float:
        return self.reward_at(self.distance())

    def get_info(self) -> dict[str, Any]:
        return self.info_at(self.distance())

    def _score(self) -> tuple[float, dict[str, Any]]:
        dist = self.distance()
        return float(self.reward_at(dist)), self.info_at(dist)


class SingleArmSampler(TaskSampler):
    """Builds a wxai table scene; the arm starts at ``init_arm_qpos`` (rad) plus uniform
    noise of ``init_joint_noise`` (rad), the gripper at ``init_gripper`` (m, default open)."""

    robot_name: ClassVar[str] = "wxai"
    arms: ClassVar[tuple[tuple[str, str], ...]] = (("arm", "gripper"),)
    cameras: ClassVar[tuple[str, ...]] = ("overview", "cam")

    def robot_config(self) -> RobotConfig:
        base = wxai_config()
        fingers = float(self.config.get("init_gripper", GRIPPER_OPEN))
        init = {"arm": list(self.config["init_arm_qpos"]), "gripper": [fingers, fingers]}
        return RobotConfig(base.name, base.groups, init, base.command_mode)

    def perturb_arm(self, rng: np.random.Generator) -> None:
        """Add the initial joint noise to the arm (in place, within the joint limits)."""
        noise = float(self.config.get("init_joint_noise", 0.0))
        arm = self.env.robots[self.robot_name].view.group("arm")
        q = arm.get_qpos(self.env.data) + uniform(rng, -noise, noise, arm.n_joints)
        arm.set_qpos(self.env.data, clip(q, arm.joint_range[:, 0], arm.joint_range[:, 1]))
