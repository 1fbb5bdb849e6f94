"""Observation spaces of the gym adapter and the conversion of task observations into them.

Observation types (``obs_type``):

- ``state``: float32 vector, the task's named state entries concatenated in
  ``Task.observation_bounds`` order; goal-conditioned tasks in the plain env also append the
  desired goal (3,) and desired - achieved (3,) (m).
- ``pixels``: uint8 image (height, width * n_cameras, 3), the cameras side by side.
- ``pixels_state``: Dict(pixels=image, state=vector).

Goal envs return Dict(observation=..., achieved_goal=(3,), desired_goal=(3,)) where
``observation`` is the state vector (``state``), the image (``pixels``), or the state vector
with an extra ``pixels`` key (``pixels_state``).

Every Box is finite; state values are clipped into their bounds (see each task's
``observation_bounds``: joint ranges, velocity caps, the workspace box).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.task import Task

OBS_TYPES = ("state", "pixels", "pixels_state")


def _box(low: np.ndarray, high: np.ndarray) -> spaces.Box:
    return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)


def _check_bounds(bounds: dict[str, tuple]) -> None:
    """Every entry's bounds finite with low <= high (a one-line UserError naming the entry);
    checked once, when the space is built."""
    for key, (low, high) in bounds.items():
        low, high = np.asarray(low, float), np.asarray(high, float)
        if not (np.isfinite(low).all() and np.isfinite(high).all()) or (low > high).any():
            raise UserError(
                f"observation entry '{key}': bounds must be finite with low <= high, got low "
                f"{np.round(low, 4).tolist()}, high {np.round(high, 4).tolist()}; check the "
                "task config (workspace_low/high, max_joint_velocity, max_object_velocity)"
            )


class ObservationBuilder:
    """Builds the observation space from a (probe) task and converts task states.

    Args:
        task: any task of the family (bounds depend on config and model only).
        obs_type: one of ``OBS_TYPES``.
        goal_env: Dict observation with achieved/desired goals.
        n_cameras, height, width: image layout for pixel observations.
    """

    def __init__(
        self, task: Task, obs_type: str, goal_env: bool, n_cameras: int, height: int, width: int
    ):
        if obs_type not in OBS_TYPES:
            raise unknown_name_error("observation type", obs_type, OBS_TYPES)
        self.obs_type = obs_type
        self.goal_env = goal_env
        for name, size in (("n_cameras", n_cameras), ("height", height), ("width", width)):
            if not isinstance(size, (int, np.integer)) or isinstance(size, bool) or size < 0:
                raise UserError(f"observation {name} must be a whole number >= 0, got {size!r}")
        self.with_goal = task.goal_conditioned and not goal_env
        bounds = dict(task.observation_bounds())
        if task.goal_conditioned:
            g_low, g_high = task.goal_bounds()
            _check_bounds({"goal": (g_low, g_high)})
            self.goal_low, self.goal_high = g_low.astype(np.float32), g_high.astype(np.float32)
            if self.with_goal:
                bounds["goal"] = (g_low, g_high)
                bounds["goal_delta"] = (g_low - g_high, g_high - g_low)
        _check_bounds(bounds)
        self.keys = list(bounds)
        self.state_space = _box(
            np.concatenate([np.asarray(bounds[k][0], float) for k in self.keys]),
            np.concatenate([np.asarray(bounds[k][1], float) for k in self.keys]),
        )
        self.image_space = spaces.Box(0, 255, (height, width * n_cameras, 3), dtype=np.uint8)
        self.space = self._space()
        self._low, self._high = self.state_space.low, self.state_space.high
        self._n_state = len(self._low)
        if task.goal_conditioned:  # the state, then the achieved and the desired goal
            self._low_goals = np.concatenate([self._low, self.goal_low, self.goal_low])
            self._high_goals = np.concatenate([self._high, self.goal_high, self.goal_high])

    @property
    def needs_images(self) -> bool:
        return self.obs_type != "state"

    def _space(self) -> spaces.Space:
        main = self.image_space if self.obs_type == "pixels" else self.state_space
        if not self.goal_env:
            if self.obs_type == "pixels_state":
                return spaces.Dict({"pixels": self.image_space, "state": self.state_space})
            return main
        goal = spaces.Box(self.goal_low, self.goal_high, dtype=np.float32)
        entries: dict[str, spaces.Space] = {"observation": main}
        if self.obs_type == "pixels_state":
            entries["pixels"] = self.image_space
        entries["achieved_goal"] = goal
        entries["desired_goal"] = spaces.Box(self.goal_low, self.goal_high, dtype=np.float32)
        return spaces.Dict(entries)

    def state(self, task: Task, goals: tuple[np.ndarray, ...] = ()) -> np.ndarray:
        """The task's state as the clipped float32 vector of ``state_space``; with ``goals``
        (achieved, desired (3,) each; goal envs) those follow it in the same vector, clipped
        into the goal bounds."""
        parts = task.state_parts(self.with_goal)  # no copies, where the task has the shortcut
        if parts is None:
            obs = task.get_observation()
            if self.with_goal:
                desired = task.desired_goal()
                obs["goal"] = desired
                obs["goal_delta"] = desired - task.achieved_goal()
            parts = [obs[k] for k in self.keys]
        low, high = self._low, self._high
        if goals:
            parts = [*parts, *goals]
            low, high = self._low_goals, self._high_goals
        try:  # the usual case: every entry a 1-D array
            vec = np.concatenate(parts, dtype=np.float32)
        except (ValueError, TypeError):
            vec = None
        if vec is None or vec.shape != low.shape:  # scalars, 0-d or n-d entries
            vec = np.concatenate([np.asarray(p, float).reshape(-1) for p in parts])
            vec = vec.astype(np.float32)
        return clip(vec, low, high, out=vec)

    def build(self, task: Task, images: dict[str, np.ndarray] | None) -> Any:
        """The observation of the current state (``images``: camera -> (H, W, 3) uint8)."""
        pixels = None
        if self.needs_images:
            pixels = np.concatenate(list((images or {}).values()), axis=1)
        if not self.goal_env:
            state = self.state(task) if self.obs_type != "pixels" else None
            if self.obs_type == "pixels":
                return pixels
            if self.obs_type == "pixels_state":
                return {"pixels": pixels, "state": state}
            return state
        # goal env: the state (if any), then the achieved and the desired goal, as one vector
        # clipped once; the entries are its parts
        goals = task.goal_views()  # no copies, where the task has the shortcut
        if goals is None:
            goals = (task.achieved_goal(), task.desired_goal())
        if self.obs_type == "pixels":
            n = self._n_state
            vec = np.concatenate(goals, dtype=np.float32)
            vec, n = clip(vec, self._low_goals[n:], self._high_goals[n:], out=vec), 0
        else:
            vec, n = self.state(task, goals), self._n_state
        out: dict[str, np.ndarray] = {"observation": pixels if n == 0 else vec[:n]}
        if self.obs_type == "pixels_state":
            out["pixels"] = pixels
        out["achieved_goal"], out["desired_goal"] = vec[n : n + 3], vec[n + 3 :]
        return out
