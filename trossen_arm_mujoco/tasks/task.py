"""Task: what an episode is. It scores (reward, success), times and observes; it never
randomizes (samplers do) and never computes control (controllers do).

Timing: ``sim_dt`` is the model timestep, ``ctrl_dt`` the control period of the scene and
``policy_dt`` (default 0.02 s) the duration of one task step. One task step runs
``policy_dt / ctrl_dt`` control ticks, each of ``ctrl_dt / sim_dt`` physics steps; both
ratios must be whole numbers (``UserError`` otherwise).

Lifecycle: a ``TaskSampler`` resets the scene, randomizes it and builds the task, then
calls ``task.reset()``; the caller then alternates ``step(action)`` and the queries
(``is_done`` = ``is_terminal() or is_timed_out()``, ``judge_success``, ``get_reward``,
``get_observation``).

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cached_property
from typing import Any, ClassVar

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.scene import Scene, whole_ratio
from trossen_arm_mujoco.tasks.observation import ObservationParts, Part, check_part

__all__ = ["DEFAULT_POLICY_DT", "Bounds", "Task"]

DEFAULT_POLICY_DT = 0.02

Bounds = dict[str, tuple[np.ndarray, np.ndarray]]


class Task:
    """Base of every task.

    Args:
        scene: the world of the episode (owned by the sampler).
        config: task config (see ``tasks.config``); keys read here: ``policy_dt``,
            ``max_episode_steps``, ``terminate_on_success``.

    Subclasses set ``name``, ``robot_name`` and override the physics hooks
    (``initialize_episode``, ``before_step``, ``after_step``), ``observation_parts`` (what
    the task observes, said once: see ``tasks.observation``), ``get_reward``,
    ``judge_success`` and ``get_task_description``. Goal-conditioned tasks also override
    ``goal_parts`` (achieved and desired goal), ``goal_reward`` and ``goal_success``.

    Derived, not overridden: ``get_observation``, ``observation_bounds``, the gym vector
    (``observed.values()``), ``achieved_goal``, ``desired_goal`` and ``goal_bounds``
    (a subclass defining one of these is refused when its class is created).
    """

    #: methods that derive from the parts; a subclass declares parts instead
    _DERIVED: ClassVar[tuple[str, ...]] = (
        "get_observation",
        "observation_bounds",
        "achieved_goal",
        "desired_goal",
        "goal_bounds",
    )

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for method in cls._DERIVED:
            if method in vars(cls):
                raise UserError(
                    f"task class {cls.__name__} defines {method}(); declare "
                    "observation_parts() (and goal_parts() for goals) instead: the dict "
                    "observation, its bounds, the gym vector and the goals derive from them"
                )

    name: ClassVar[str] = ""
    robot_name: ClassVar[str] = ""
    goal_conditioned: ClassVar[bool] = False

    def __init__(self, scene: Scene, config: Mapping[str, Any]):
        self.scene = scene
        self.config = dict(config)
        self.sim_dt = scene.sim_dt
        self.ctrl_dt = scene.ctrl_dt
        self.policy_dt = float(self.config.get("policy_dt", DEFAULT_POLICY_DT))
        self.n_ctrl_steps = whole_ratio(self.policy_dt, self.ctrl_dt, "policy_dt", "ctrl_dt")
        self.max_episode_steps = int(self.config.get("max_episode_steps", 0)) or None
        self.n_steps = 0

    # -- layers ---------------------------------------------------------------------------
    @property
    def robot(self):
        """The robot this task acts through (``sim.scene.Scene.robots[robot_name]``)."""
        return self.scene.robots[self.robot_name]

    @property
    def data(self):
        """The scene's ``MjData``."""
        return self.scene.data

    # -- physics hooks --------------------------------------------------------------------
    def initialize_episode(self) -> None:
        """Called by ``reset`` once the sampler has set the scene (e.g. place markers), with
        the positions up to date (``mj_kinematics``); a full ``mj_forward`` follows."""

    def before_step(self, action: Mapping[str, np.ndarray]) -> None:
        """Hand the commands (move group -> command vector) to the robot."""
        self.robot.update_control(action)

    def after_step(self) -> None:
        """Called after the physics of one task step (bookkeeping)."""

    # -- episodic API ---------------------------------------------------------------------
    def reset(self) -> dict[str, np.ndarray]:
        """Start the episode from the current scene: counters to zero, controls holding the
        state, hooks run. Returns the first observation."""
        self.n_steps = 0
        mujoco.mj_kinematics(self.scene.model, self.data)  # positions: all that holding needs
        self.robot.hold(self.data)
        self.initialize_episode()
        self.scene.forward()
        return self.get_observation()

    def apply_action(self, action: Mapping[str, np.ndarray]) -> None:
        """First half of a step: validate and hand over the commands (no physics)."""
        if not isinstance(action, dict) and not isinstance(action, Mapping):
            raise UserError(
                f"task '{self.name}': action must be a dict move group -> command, "
                f"got {type(action).__name__}"
            )
        self.before_step(action)

    def finish_step(self) -> None:
        """Second half of a step, after the physics: count it and run ``after_step``."""
        self.n_steps += 1
        self.after_step()

    def advance(self, action: Mapping[str, np.ndarray]) -> None:
        """One task step without the queries: commands in, then ``n_ctrl_steps`` control
        ticks of ``scene.step`` (``policy_dt`` of simulated time), then ``finish_step``."""
        self.apply_action(action)
        self.scene.step(self.n_ctrl_steps)
        self.finish_step()

    def step(self, action: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], float, bool]:
        """One task step: commands in, ``policy_dt`` of simulated time.

        Returns:
            (observation, reward, done).
        """
        self.advance(action)
        return self.get_observation(), self.get_reward(), self.is_done()

    def is_terminal(self) -> bool:
        """The episode ends for a reason other than time (success when
        ``terminate_on_success``)."""
        return bool(self.config.get("terminate_on_success", False)) and self.judge_success()

    def is_timed_out(self) -> bool:
        """``max_episode_steps`` task steps taken (never, when the config sets none)."""
        return self.max_episode_steps is not None and self.n_steps >= self.max_episode_steps

    def is_done(self) -> bool:
        """``is_terminal() or is_timed_out()``."""
        return self.is_terminal() or self.is_timed_out()

    def judge_success(self) -> bool:
        """Whether the episode is a success in the current state; subclasses decide."""
        raise NotImplementedError

    def get_task_description(self) -> str:
        """The task in one line of words (the language instruction of a dataset)."""
        raise NotImplementedError

    def get_reward(self) -> float:
        """The reward of the current state; subclasses define it."""
        raise NotImplementedError

    def get_info(self) -> dict[str, Any]:
        """Per-step diagnostics; always has ``is_success``."""
        return {"is_success": self.judge_success()}

    #: the reward of the state being scored, while ``score`` runs (None otherwise)
    _reward_now: float | None = None

    def score(self) -> tuple[float, dict[str, Any]]:
        """(reward, info) of the current state: ``float(get_reward())``, then ``get_info()``.
        The gym env scores each step with it. While ``get_info`` runs, ``current_reward()``
        is the reward just computed (the state cannot change in between)."""
        reward = self._reward_now = float(self.get_reward())
        try:
            return reward, self.get_info()
        finally:
            self._reward_now = None

    def current_reward(self) -> float:
        """``float(get_reward())`` of the current state; inside ``score`` the value it has
        just computed (e.g. for a success defined by the reward, without a second
        evaluation)."""
        reward = self._reward_now
        return float(self.get_reward()) if reward is None else reward

    # -- observations: declared once, as parts ----------------------------------------------
    def observation_parts(self) -> Sequence[Part]:
        """What the task observes, in order: named ``Part`` s whose values are live views of
        ``data`` where they exist and small callables otherwise, with finite bounds from the
        config and the model only. Called once per task (see ``observed``)."""
        raise NotImplementedError(f"task '{self.name}' declares no observation_parts()")

    @cached_property
    def observed(self) -> ObservationParts:
        """The task's ``observation_parts()`` (names checked unique; bounds checked finite and
        ordered when first used): the source of the dict, the bounds and the gym vector."""
        return ObservationParts(self.observation_parts())

    def get_observation(self) -> dict[str, np.ndarray]:
        """name -> current value of every observation part, float64 copies (1-D)."""
        return self.observed.as_dict()

    def observation_bounds(self) -> Bounds:
        """name -> (low, high) of every observation part (copies); finite, valid before any
        episode."""
        return self.observed.bounds()

    # -- goals (goal-conditioned tasks) ---------------------------------------------------
    def goal_parts(self) -> tuple[Part, Part]:
        """(achieved goal, desired goal) as parts (e.g. an observation part and the task's
        goal array); the goals, their bounds and the goal entries of the gym observations
        derive from them. Called once per task (see ``goals``)."""
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    @cached_property
    def goals(self) -> tuple[Part, Part]:
        """``goal_parts()`` (their bounds are checked when first used: ``goal_bounds``)."""
        achieved, desired = self.goal_parts()
        return achieved, desired

    def achieved_goal(self) -> np.ndarray:
        """The achieved goal now (a copy)."""
        return np.array(self.goals[0].read(), dtype=float).reshape(-1)

    def desired_goal(self) -> np.ndarray:
        """The desired goal now (a copy)."""
        return np.array(self.goals[1].read(), dtype=float).reshape(-1)

    def goal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) covering both goals (copies; checked finite and ordered, sizes equal):
        the bounds of achieved and desired goals alike, so either may stand for the other
        (HER relabelling)."""
        achieved, desired = self.goals
        for part in (achieved, desired):
            check_part(part)
        if achieved.size != desired.size:
            raise UserError(
                f"task '{self.name}': achieved goal '{achieved.name}' has {achieved.size} "
                f"values, desired goal '{desired.name}' {desired.size}"
            )
        return np.minimum(achieved.low, desired.low), np.maximum(achieved.high, desired.high)

    def goal_reward(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """Rewards of achieved goals against desired ones, (batch,) from (batch, goal
        dim) arrays (goal-conditioned tasks only; ``GoalEnv.compute_reward``)."""
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def goal_success(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """Success of achieved goals against desired ones, (batch,) bools from
        (batch, goal dim) arrays (goal-conditioned tasks only)."""
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")
