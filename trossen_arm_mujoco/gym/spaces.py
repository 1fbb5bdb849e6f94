"""Observation spaces of the gym adapter and the conversion of task observations into them.

``obs_type``: ``state`` (a float32 vector, the task's observation parts concatenated in
order; goal-conditioned tasks in the plain env append the desired goal and desired -
achieved, (3,) each for the wxai tasks, m), ``pixels`` (uint8 (height, width * n_cameras, 3),
the cameras side by side) or ``pixels_state`` (Dict(pixels=..., state=...)). Goal envs return
Dict(observation=..., achieved_goal, desired_goal). Everything derives from the task's
observation parts (``tasks.observation``); every Box is finite and state values are clipped
into their bounds (joint ranges, velocity caps, the workspace box).

Docs: docs/gym/index.md, and each id's page under docs/gym/.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.tasks.task import Task

__all__ = ["OBS_TYPES", "ObservationBuilder"]

OBS_TYPES = ("state", "pixels", "pixels_state")


def _box(low: np.ndarray, high: np.ndarray) -> spaces.Box:
    return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)


class ObservationBuilder:
    """Builds the observation space from a (probe) task's observation parts and turns a
    task's current state into observations.

    Everything comes from the task's parts (``Task.observed``, ``Task.goals``): the state
    vector is the parts' values concatenated in order (live views read in place, computed
    parts called once), then, for a goal-conditioned task in the plain env, the desired goal
    and desired - achieved; the Box bounds are the parts' bounds in the same order. Every
    task of the family (each episode's) has the same parts as the probe.

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
        observed = task.observed
        self.keys = list(observed.names)
        low, high = observed.low_high()  # checked: finite, low <= high (a line naming a part)
        if task.goal_conditioned:
            g_low, g_high = task.goal_bounds()
            self.goal_low, self.goal_high = g_low.astype(np.float32), g_high.astype(np.float32)
            if self.with_goal:
                self.keys += ["goal", "goal_delta"]
                low = np.concatenate([low, g_low, g_low - g_high])
                high = np.concatenate([high, g_high, g_high - g_low])
        self.state_space = _box(low, high)
        self.image_space = spaces.Box(0, 255, (height, width * n_cameras, 3), dtype=np.uint8)
        self.space = self._space()
        self._low, self._high = self.state_space.low, self.state_space.high
        self._n_state = len(self._low)
        if task.goal_conditioned:  # the state, then the achieved and the desired goal
            self._low_goals = np.concatenate([self._low, self.goal_low, self.goal_low])
            self._high_goals = np.concatenate([self._high, self.goal_high, self.goal_high])

    @property
    def needs_images(self) -> bool:
        """Whether observations include camera images (every type but ``state``)."""
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
        """The task's state as the clipped float32 vector of ``state_space``: its parts'
        values in order (no copies before the one concatenation); with ``goals``
        (achieved, desired; goal envs) those follow it in the same vector, clipped into the
        goal bounds."""
        parts = task.observed.values()
        if self.with_goal:
            achieved, desired = task.goals
            goal = desired.read()
            parts += (goal, goal - achieved.read())
        low, high = self._low, self._high
        if goals:
            parts += goals
            low, high = self._low_goals, self._high_goals
        try:  # the usual case: every value a 1-D array
            vec = np.concatenate(parts, dtype=np.float32)
        except (ValueError, TypeError):
            vec = None
        if vec is None or vec.shape != low.shape:  # scalars, 0-d or n-d values
            vec = np.concatenate([np.asarray(p, float).reshape(-1) for p in parts])
            if vec.shape != low.shape:
                raise UserError(
                    f"task '{task.name}': its observation parts gave {vec.size} values, "
                    f"their bounds {low.size}; a computed part returns as many values as "
                    "its bounds have"
                )
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
        achieved, desired = task.goals
        goals = (achieved.read(), desired.read())
        if self.obs_type == "pixels":
            n = self._n_state
            vec = np.concatenate(goals, dtype=np.float32)
            vec, n = clip(vec, self._low_goals[n:], self._high_goals[n:], out=vec), 0
        else:
            vec, n = self.state(task, goals), self._n_state
        out: dict[str, np.ndarray] = {"observation": pixels if n == 0 else vec[:n]}
        if self.obs_type == "pixels_state":
            out["pixels"] = pixels
        g = n + self.goal_low.size
        out["achieved_goal"], out["desired_goal"] = vec[n:g], vec[g:]
        return out
