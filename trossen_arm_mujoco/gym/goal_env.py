"""TrossenMujocoGoalEnv: the goal-conditioned variant (for HER and friends).

Observations are ``Dict(observation, achieved_goal, desired_goal)`` (see ``gym.spaces``).
The reward depends on the goals only: ``goal_reward_type`` ``sparse`` (-1 until the achieved
goal is within ``success_tolerance`` of the desired goal, then 0) or ``dense`` (-distance, m).
``compute_reward``, ``compute_terminated`` and ``compute_truncated`` accept single goals (3,)
or batches (..., 3); ``step`` uses the same functions on the observation it returns, so the
two always agree.

Docs: docs/gym/index.md, docs/reference/gym.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.env import TrossenMujocoEnv
from trossen_arm_mujoco.tasks import registry

__all__ = ["TrossenMujocoGoalEnv"]


class TrossenMujocoGoalEnv(TrossenMujocoEnv):
    """Goal-conditioned gym env over a goal-conditioned task (reach, push, pick_place)."""

    goal_env = True

    def __init__(self, task: str = registry.DEFAULT_ARM_TASK, **kwargs: Any):
        if not registry.load(task).task_class().goal_conditioned:
            goal_tasks = [
                n for n in registry.names() if registry.load(n).task_class().goal_conditioned
            ]
            raise UserError(
                f"task '{task}' is not goal-conditioned; goal-conditioned tasks: "
                + ", ".join(goal_tasks)
            )
        super().__init__(task, **kwargs)

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray | float:
        """Reward of goal pairs; a float for single goals.

        Args:
            achieved_goal: (..., 3) achieved goals (m, world frame, for the wxai tasks).
            desired_goal: (..., 3) desired goals, likewise.
            info: the step's ``info`` (unused; gymnasium-robotics' signature).

        Returns:
            (...) rewards.
        """
        reward = self.probe.goal_reward(achieved_goal, desired_goal)
        if type(reward) is float:  # one pair (the step's)
            return reward
        return float(reward) if np.ndim(reward) == 0 else reward

    def compute_terminated(self, achieved_goal, desired_goal, info) -> np.ndarray | bool:
        """Success when ``terminate_on_success``, else False.

        Args:
            achieved_goal: (..., 3) achieved goals (m).
            desired_goal: (..., 3) desired goals (m).
            info: the step's ``info`` (unused).

        Returns:
            (...) booleans.
        """
        success = self.probe.goal_success(achieved_goal, desired_goal)
        done = success & bool(self.config.get("terminate_on_success", False))
        return bool(done) if np.ndim(done) == 0 else done

    def compute_truncated(self, achieved_goal, desired_goal, info) -> np.ndarray | bool:
        """Always False (time limits come from the TimeLimit wrapper).

        Args:
            achieved_goal: (..., 3) achieved goals (m).
            desired_goal: (..., 3) desired goals (m).
            info: the step's ``info`` (unused).

        Returns:
            (...) booleans, all False.
        """
        shape = np.shape(achieved_goal)[:-1]
        return False if shape == () else np.zeros(shape, dtype=bool)

    def _evaluate(self, obs: Any) -> tuple[float, bool, dict[str, Any]]:
        """Reward and success of the goals just observed, as ``compute_reward`` and
        ``compute_terminated`` give them for the same goals."""
        info = self._with_safety(self.task.get_info())
        achieved, desired = obs["achieved_goal"], obs["desired_goal"]
        success = info["is_success"] = bool(self.probe.goal_success(achieved, desired))
        reward = float(self.compute_reward(achieved, desired, info))
        # compute_terminated(achieved, desired, info), from the success just computed
        terminated = success and bool(self.config.get("terminate_on_success", False))
        return reward, terminated, info
