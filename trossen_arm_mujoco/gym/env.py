"""TrossenMujocoEnv: one gymnasium.Env over any registered task.

The env adapts; it does not score or randomize. The task's sampler builds the world and
samples episodes from ``self.np_random``; the task scores; ``gym.actions`` turns actions into
commands (the robot layer keeps the arms above the safety floor, ``gym.safety`` reports it);
``gym.stepping`` advances time; ``gym.spaces`` shapes the observations. Every keyword
argument is checked once, at construction (a one-line ``UserError``); a malformed action or
reset option is an ``InvalidInput`` (``gym.inputs``). After ``close()``, ``step`` and
``render`` raise until ``reset()`` reopens the env.

Docs: docs/gym/index.md (options, reward, ``info``), one page per id under docs/gym/.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.gym.actions import ACTION_MODES, ActionMapper
from trossen_arm_mujoco.gym.inputs import reset_options
from trossen_arm_mujoco.gym.safety import safety_info
from trossen_arm_mujoco.gym.spaces import OBS_TYPES, ObservationBuilder
from trossen_arm_mujoco.gym.stepping import STEPPING_MODES, make_stepper
from trossen_arm_mujoco.sim.cameras import check_can_render
from trossen_arm_mujoco.sim.closing import close_at_exit, forget
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.config import merge_overrides
from trossen_arm_mujoco.tasks.config_key import Key
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.task import Task

__all__ = ["ENV_OPTIONS", "RENDER_MODES", "TrossenMujocoEnv", "has_display"]

RENDER_MODES = ("rgb_array", "human")
ENV_OPTIONS = (
    "task",
    "obs_type",
    "action_mode",
    "render_mode",
    "stepping",
    "width",
    "height",
    "cameras",
    "randomize",
    "shadows",
    "antialias",
    "visual",
)


#: Image sizes (pixels); the model's offscreen buffer bounds them further when rendering.
_IMAGE_SIZE = Key("int", 1, 16384)
_CLOSED = "this env is closed; call reset() to reopen it (or make a new one)"


def _check_choice(kind: str, value: Any, valid: Sequence[str]) -> None:
    if not isinstance(value, str) or value not in valid:
        raise unknown_name_error(kind, str(value), valid)


def _check_cameras(cameras: Any) -> list[str] | None:
    """The ``cameras`` keyword argument as a list of names (None: the default)."""
    if cameras is None:
        return None
    names = [cameras] if isinstance(cameras, str) else cameras
    if not isinstance(names, (list, tuple)) or not all(isinstance(c, str) for c in names):
        raise UserError(
            f"env keyword argument cameras: expected a camera name or a list of them, "
            f"got {cameras!r:.60}"
        )
    return list(names)


def has_display() -> bool:
    """Whether a window can be opened (macOS/Windows always; Linux needs X11 or Wayland)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class TrossenMujocoEnv(gymnasium.Env):
    """Gymnasium env over a registered task.

    Args:
        task: registered task name (``tasks.registry.names()``).
        obs_type: ``state`` | ``pixels`` | ``pixels_state`` (see ``gym.spaces``).
        action_mode: ``joint_position`` | ``joint_rel_position`` | ``ee_delta`` (see
            ``gym.actions``).
        render_mode: None | ``rgb_array`` | ``human`` (a passive MuJoCo viewer; without a
            display: a warning at construction, and nothing is shown).
        stepping: ``fast`` | ``paused`` | ``realtime`` (see ``gym.stepping``).
        width: image width (pixels) of pixel observations and ``rgb_array`` renders.
        height: image height (pixels), likewise.
        cameras: cameras of pixel observations and renders; None: the scene's first one.
        randomize: domain randomization of every episode, as the task config's
            ``randomization`` section says (override it with ``randomization={...}``); the
            record of the episode is ``info["randomization"]`` at reset.
        shadows: whether the key light casts shadows (False renders pixels about twice as
            fast with software rendering).
        antialias: whether edges are smoothed by multisampling (False: one sample a pixel,
            about twice as fast with software rendering; ``sim.looks``).
        visual: ``own`` (the project's arm shapes) | ``menagerie`` (the official Trossen
            meshes of a MuJoCo Menagerie checkout named by ``TROSSEN_MENAGERIE_DIR``; see
            ``sim.looks``). Only what is drawn changes; physics is the same.
        **config: the task's config keys, overriding its YAML file.

    Raises:
        UserError: a bad keyword argument or config value (one line naming it and what is
            valid).
    """

    # render_fps: 1 / policy_dt of the task (its YAML config), set per instance
    metadata = {"render_modes": list(RENDER_MODES), "render_fps": None}
    goal_env = False

    def __init__(
        self,
        task: str = registry.DEFAULT_ARM_TASK,
        *,
        obs_type: str = "state",
        action_mode: str = "joint_position",
        render_mode: str | None = None,
        stepping: str = "fast",
        width: int = 128,
        height: int = 128,
        cameras: Sequence[str] | None = None,
        randomize: bool = False,
        shadows: bool = True,
        antialias: bool = True,
        visual: str = "own",
        **config: Any,
    ):
        entry = registry.load(task)
        defaults = entry.load_config()  # the YAML file, checked
        for key in config:
            if key not in defaults:
                raise unknown_name_error("env option or config key", key, [*ENV_OPTIONS, *defaults])
        _check_choice("observation type", obs_type, OBS_TYPES)
        _check_choice("action mode", action_mode, ACTION_MODES)
        _check_choice("stepping mode", stepping, STEPPING_MODES)
        width = _IMAGE_SIZE.check("env keyword argument width", width)
        height = _IMAGE_SIZE.check("env keyword argument height", height)
        randomize = Key("bool").check("env keyword argument randomize", randomize)
        cameras = _check_cameras(cameras)
        self.config = merge_overrides(entry.config, defaults, config, entry.keys)  # kwargs, checked
        looks = SceneLooks(shadows=shadows, antialias=antialias, visual=visual)
        if render_mode is not None:
            _check_choice("render mode", render_mode, RENDER_MODES)
        self._headless = render_mode == "human" and not has_display()
        if self._headless:
            warnings.warn(
                "render_mode='human' needs a display (DISPLAY/WAYLAND_DISPLAY is not set); "
                "nothing will be shown. Use render_mode='rgb_array' for images.",
                stacklevel=2,
            )
        sampler_cls = entry.sampler_class()
        if cameras is None:
            cameras = list(sampler_cls.cameras[:1])
        renders = obs_type != "state" or render_mode == "rgb_array"
        if renders and not cameras:
            raise UserError("pixel observations and rgb_array renders need at least one camera")
        if renders:
            check_can_render()  # fail now, not with a hang at the first image
        self.task_name = task
        self.obs_type, self.action_mode, self.render_mode = obs_type, action_mode, render_mode
        settings = SamplerSettings(
            command_mode=action_mode,
            camera_names=tuple(cameras),
            height=height,
            width=width,
            randomize=randomize,
            looks=looks,
            floor_margin=self.config["safety_margin"],
        )
        self.sampler = sampler_cls(self.config, settings)
        self.scene = self.sampler.scene
        robot = self.scene.robots[sampler_cls.robot_name]
        self.actions = ActionMapper(robot, sampler_cls.arms, action_mode, self.config)
        self.probe = probe = self.sampler.make_task()  # episode-independent queries
        self.observations = ObservationBuilder(
            probe, obs_type, self.goal_env, len(cameras), height, width
        )
        self.action_space = gymnasium.spaces.Box(*self.actions.bounds(), dtype=np.float32)
        self.observation_space = self.observations.space
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / probe.policy_dt))}
        self.stepper = make_stepper(stepping)
        self.task: Task | None = None
        self._viewer = None
        self._closed = False
        close_at_exit(self)  # renderers, viewer window and stepping thread, if never closed

    # -- gymnasium API --------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode (``seed``: see gymnasium). ``options``: None, ``{}``, or
        ``{"object_poses": {object name: 7 values [xyz m, quat wxyz]}}`` to place the named
        objects instead of their sampled poses; an unknown key or a bad value is an
        ``InvalidInput`` (``gym.inputs``) listing what is accepted."""
        poses = reset_options(options, self.scene.objects)
        if self._closed:  # reopen: what close() released is made again when needed
            self._closed = False
            close_at_exit(self)
        super().reset(seed=seed)
        if seed is not None:
            self.action_space.seed(seed)
            self.observation_space.seed(seed)
        self.stepper.stop()
        self.task = self.sampler.next_task(self.np_random, object_poses=poses)
        self.actions.reset(self.scene.data)
        obs = self._observe()
        info = self._with_safety(self.task.get_info())
        if self.sampler.randomization is not None:
            info["randomization"] = self.sampler.randomization
        self.stepper.start(self.task)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        if self.task is None:  # never reset, or closed: nothing more on the hot path
            raise UserError(_CLOSED if self._closed else "call reset() before step()")
        with self.stepper.lock:
            commands = self.actions(self.scene.data, action)
        self.stepper.step(self.task, commands)
        with self.stepper.lock:
            obs = self._observe()
            reward, terminated, info = self._evaluate(obs)
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def render(self):
        if self._closed:
            raise UserError(_CLOSED)
        if self.render_mode == "rgb_array":
            with self.stepper.lock:
                return np.concatenate(list(self.scene.render_images().values()), axis=1)
        if self.render_mode == "human":
            self._sync_viewer()
        return None

    def close(self):
        if getattr(self, "_closed", True):  # closed already, or never fully built
            return
        self._closed = True
        self.task = None  # step() now says the env is closed, until reset()
        forget(self)
        self.stepper.close()
        if self._viewer is not None:
            from trossen_arm_mujoco.viewer import close_viewer

            close_viewer(*self._viewer)  # and wait for its threads (exiting earlier crashes)
            self._viewer = None
        self.sampler.close()

    # -- internals ------------------------------------------------------------------------
    def _observe(self) -> Any:
        images = self.scene.render_images() if self.observations.needs_images else None
        return self.observations.build(self.task, images)

    def _with_safety(self, info: dict[str, Any]) -> dict[str, Any]:
        """The task's ``info`` with the safety floor's report of this step (the robot's:
        ``gym.safety``)."""
        return safety_info(info, self.actions.robot.floor_report)

    def _evaluate(self, obs: Any) -> tuple[float, bool, dict[str, Any]]:
        """(reward, terminated, info) of the state just observed: the task's ``score``."""
        reward, info = self.task.score()
        return reward, bool(self.task.is_terminal()), self._with_safety(info)

    def _sync_viewer(self) -> None:
        if self._headless:
            return
        if self._viewer is None:
            from trossen_arm_mujoco.viewer import launch_viewer

            try:
                self._viewer = launch_viewer(self.scene.model, self.scene.data, timeout=None)
            except Exception as exc:  # no GL / no window system
                raise UserError(f"cannot open the MuJoCo viewer: {exc}") from exc
        with self.stepper.lock:
            self._viewer[0].sync()
