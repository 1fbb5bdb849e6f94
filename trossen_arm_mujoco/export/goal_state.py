"""The goal of a goal-conditioned episode (a single arm's ``pick_place`` or ``push``) in an
export with the sim's features: three values after the object poses in
``observation.environment_state``, and ``next.success`` judged from the achieved object's
distance to it, as the task judges it.

Docs: docs/cli/export.md.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.data.schema import ENV_STATE_DIM
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry

__all__ = ["GOAL_NAMES", "GoalJudge", "episode_goal", "goal_judge"]

#: Names of the goal's values in ``observation.environment_state`` (m, world frame).
GOAL_NAMES: tuple[str, ...] = ("goal_x", "goal_y", "goal_z")


def episode_goal(episode: Episode) -> np.ndarray | None:
    """The episode's ``goal`` attribute, (3,) m, world frame (None: it has none).

    Raises:
        UserError: a goal that is not 3 finite numbers, naming the file.
    """
    value = episode.attrs.get("goal")
    if value is None:
        return None
    try:
        goal = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        goal = None
    if goal is None or not np.all(np.isfinite(goal)):
        raise UserError(
            f"{episode.path.name}: its goal attribute is not 3 finite numbers ({value!r}); "
            "record the episode again"
        )
    return goal


class GoalJudge:
    """Success as a goal-conditioned task judges it: the achieved object's centre within
    ``tolerance`` (m) of the goal.

    Attributes:
        index: the achieved object's place among the episode's objects.
        tolerance: the task's ``success_tolerance`` (m).
    """

    def __init__(self, index: int, tolerance: float) -> None:
        self.index, self.tolerance = int(index), float(tolerance)

    def success(self, poses: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Per frame, whether the object is within the tolerance of ``goal``.

        Args:
            poses: ``(K, 7k)`` object poses (xyz m + quat wxyz each, world).
            goal: ``(3,)`` m, world.

        Returns:
            bool ``(K,)``.
        """
        start = self.index * ENV_STATE_DIM
        centre = np.asarray(poses, dtype=np.float64)[:, start : start + 3]
        return np.linalg.norm(centre - goal, axis=1) < self.tolerance


def goal_judge(entry: registry.TaskEntry | None, objects: list[str]) -> GoalJudge | None:
    """How ``entry``'s task judges success from the recorded object poses, or None where it
    does not (no task, not goal-conditioned, or its achieved goal is not an object's
    centre, e.g. the reach task's tool position).

    Args:
        entry: the episode's registered task (None: a vendor recording).
        objects: the episode's object names, in env_state order.
    """
    if entry is None:
        return None
    try:
        cls = entry.task_class()
    except Exception:  # a broken task module: the export says so where it needs the task
        return None
    if not getattr(cls, "goal_conditioned", False):
        return None
    part = str(getattr(cls, "achieved_part", ""))
    names = [f"{obj}_pos" for obj in objects]
    if part not in names:
        return None
    tolerance = entry.load_config().get("success_tolerance")
    if tolerance is None:
        return None
    return GoalJudge(names.index(part), float(tolerance))
