"""Task: what an episode is. It scores (reward, success), times and observes; it never
randomizes (samplers do) and never computes control (controllers do).

Timing: ``sim_dt`` is the model timestep, ``ctrl_dt`` the control period of the env and
``policy_dt`` (default 0.02 s) the duration of one task step. One task step runs
``policy_dt / ctrl_dt`` control ticks, each of ``ctrl_dt / sim_dt`` physics steps; both
ratios must be whole numbers (``UserError`` otherwise).

Lifecycle: a ``TaskSampler`` resets the env, randomizes the scene and builds the task, then
calls ``task.reset()``; the caller then alternates ``step(action)`` and the queries
(``is_done`` = ``is_terminal() or is_timed_out()``, ``judge_success``, ``get_reward``,
``get_observation``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.env import MujocoEnv, whole_ratio

DEFAULT_POLICY_DT = 0.02

Bounds = dict[str, tuple[np.ndarray, np.ndarray]]


_TRUSTED: dict[tuple[type, str], bool] = {}


def _owner(cls: type, name: str) -> type | None:
    """The class of ``cls.__mro__`` that defines ``name`` (None when none does)."""
    return next((k for k in cls.__mro__ if name in vars(k)), None)


def trusts_shortcut(cls: type, shortcut: str) -> bool:
    """Whether instances of ``cls`` may use the method ``shortcut`` in place of the methods
    it reproduces.

    The class defining ``shortcut`` names those methods in its own ``_shortcuts``
    (``{shortcut: (method, ...)}``). The shortcut is trusted while each of them is defined by
    that class or by a class above it: a subclass overriding one of them (e.g. its own
    ``get_reward``) is served by its override, never by a shortcut written for the parent.
    """
    key = (cls, shortcut)
    trusted = _TRUSTED.get(key)
    if trusted is None:
        owner = _owner(cls, shortcut)
        covers = None if owner is None else vars(owner).get("_shortcuts", {}).get(shortcut)
        trusted = covers is not None and all(
            issubclass(owner, _owner(cls, name) or object) for name in covers
        )
        _TRUSTED[key] = trusted
    return trusted


class Task:
    """Base of every task.

    Args:
        env: the world of the episode (owned by the sampler).
        config: task config (see ``tasks.config``); keys read here: ``policy_dt``,
            ``max_episode_steps``, ``terminate_on_success``.

    Subclasses set ``name``, ``robot_name`` and override the physics hooks
    (``initialize_episode``, ``before_step``, ``after_step``), ``get_observation`` with
    ``observation_bounds``, ``get_reward``, ``judge_success`` and ``get_task_description``
    (and shortcuts named in ``_shortcuts``: ``_score`` where reward and diagnostics share
    work; see ``trusts_shortcut``).
    Goal-conditioned tasks also override ``achieved_goal``, ``desired_goal``, ``goal_bounds``
    and ``goal_reward``.
    """

    name: ClassVar[str] = ""
    robot_name: ClassVar[str] = ""
    goal_conditioned: ClassVar[bool] = False

    def __init__(self, env: MujocoEnv, config: Mapping[str, Any]):
        self.env = env
        self.config = dict(config)
        self.sim_dt = env.sim_dt
        self.ctrl_dt = env.ctrl_dt
        self.policy_dt = float(self.config.get("policy_dt", DEFAULT_POLICY_DT))
        self.n_ctrl_steps = whole_ratio(self.policy_dt, self.ctrl_dt, "policy_dt", "ctrl_dt")
        self.max_episode_steps = int(self.config.get("max_episode_steps", 0)) or None
        self.n_steps = 0

    # -- layers ---------------------------------------------------------------------------
    @property
    def robot(self):
        """The robot this task acts through (``sim.env.MujocoEnv.robots[robot_name]``)."""
        return self.env.robots[self.robot_name]

    @property
    def data(self):
        return self.env.data

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
        mujoco.mj_kinematics(self.env.model, self.data)  # positions: all that holding needs
        self.robot.hold(self.data)
        self.initialize_episode()
        self.env.forward()
        return self.get_observation()

    def apply_action(self, action: Mapping[str, np.ndarray]) -> None:
        """First half of a step: validate and hand over the commands (no physics)."""
        if type(action) is not dict and not isinstance(action, Mapping):
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
        ticks of ``env.step`` (``policy_dt`` of simulated time), then ``finish_step``."""
        self.apply_action(action)
        self.env.step(self.n_ctrl_steps)
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
        raise NotImplementedError

    def get_task_description(self) -> str:
        raise NotImplementedError

    def get_reward(self) -> float:
        raise NotImplementedError

    def get_info(self) -> dict[str, Any]:
        """Per-step diagnostics; always has ``is_success``."""
        return {"is_success": self.judge_success()}

    #: shortcut method -> the methods whose results it reproduces (see ``trusts_shortcut``)
    _shortcuts: ClassVar[dict[str, tuple[str, ...]]] = {}

    def score(self) -> tuple[float, dict[str, Any]]:
        """(reward, info) of the current state: ``float(get_reward())`` and ``get_info()``.
        The gym env scores each step with it.

        A task class whose reward and diagnostics share work computes both at once in
        ``_score``, listed in its ``_shortcuts`` with the methods whose results that
        reproduces; ``score`` uses it only while a subclass overrides none of them, so
        overriding ``get_reward`` or ``get_info`` keeps working as documented.
        """
        if trusts_shortcut(type(self), "_score"):
            return self._score()
        return float(self.get_reward()), self.get_info()

    def _score(self) -> tuple[float, dict[str, Any]]:
        raise NotImplementedError

    # -- observations ---------------------------------------------------------------------
    def get_observation(self) -> dict[str, np.ndarray]:
        """Named state vectors (float64), keys and shapes as in ``observation_bounds``."""
        raise NotImplementedError

    def observation_bounds(self) -> Bounds:
        """name -> (low, high) of every ``get_observation`` entry; finite, from the config and
        the model only (valid before any episode)."""
        raise NotImplementedError

    def state_parts(self, with_goal: bool = False) -> list[np.ndarray] | None:
        """The values of ``get_observation()`` in ``observation_bounds`` order, then, with
        ``with_goal``, the desired goal and desired - achieved goal (m): the pieces of a flat
        state vector, read without copies. Entries may be live views of ``data`` (they follow
        the simulation: use them before the next step). None when the task has no such
        shortcut; the gym env then builds the vector from ``get_observation``."""
        return None

    # -- goals (goal-conditioned tasks) ---------------------------------------------------
    def achieved_goal(self) -> np.ndarray:
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def desired_goal(self) -> np.ndarray:
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def goal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def goal_reward(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def goal_success(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        raise NotImplementedError(f"task '{self.name}' is not goal-conditioned")

    def goal_score(self, achieved: np.ndarray, desired: np.ndarray) -> tuple[float, bool]:
        """(reward, success) of one goal pair (3,): ``goal_reward`` and ``goal_success``, from
        one evaluation where the class has the ``_goal_score`` shortcut (see
        ``trusts_shortcut``). The goal env scores each step with it."""
        if trusts_shortcut(type(self), "_goal_score"):
            return self._goal_score(achieved, desired)
        return float(self.goal_reward(achieved, desired)), bool(
            self.goal_success(achieved, desired)
        )

    def _goal_score(self, achieved: np.ndarray, desired: np.ndarray) -> tuple[float, bool]:
        raise NotImplementedError

    def goal_views(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(achieved goal, desired goal) (3,) each, read without copies: they may be live
        views of ``data`` (use them before the next step). None when the task has no such
        shortcut; the gym env then calls ``achieved_goal`` and ``desired_goal``."""
        return None
