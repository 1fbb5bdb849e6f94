"""KitPolicyEnv: a bimanual task in the joint flavour, observed and acted on in a dataset's
layout, so a policy trained on an export runs in the sim unchanged.

One env is one registered Stationary AI task (or a Mobile AI task in the ``mobileai``
layout) at a chosen rate ``fps``. Observations are LeRobot's gym dict (``agent_pos``,
``velocity``, ``environment_state``, ``pixels``; float32 in the ``kit14`` or ``vendor16``
layout: rad, gripper m, world-frame object poses); actions are joint goals in the same layout,
sent as Trossen's LeRobot plugin sends them, through the real arm controller's checks (the
first refused setpoint ends the episode, failed: ``info["fault"]``). ``reset(seed=s)`` draws
from a stream of its own (``episode_generator``), never a recording seed's.

Docs: docs/cli/eval.md, docs/train-eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.eval.mobile_base import MOBILE_LAYOUTS, MobileBase, mobile_names
from trossen_arm_mujoco.gym.inputs import reset_options
from trossen_arm_mujoco.real.arm_controller import GOAL_TIME_FACTOR, KitController
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, LAYOUTS, MOBILEAI_LAYOUT, VENDOR16_LAYOUT
from trossen_arm_mujoco.robot.lerobot_keys import (
    ACTION_KEY,
    ENV_STATE_KEY,
    STATE_KEY,
    VELOCITY_KEY,
    image_key,
)
from trossen_arm_mujoco.sim.camera_settings import CameraSettings, parse_cameras, parse_image_size
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.closing import close_at_exit, forget
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_KEY
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = [
    "BASE_SIM_DT",
    "EVAL_STREAM",
    "LEROBOT_KEYS",
    "RENDER_CAMERA",
    "KitPolicyEnv",
    "episode_generator",
    "episode_length_of",
    "feature_spec",
    "parse_cameras",
    "parse_image_size",
    "controller_timing",
    "rate_timing",
    "task_layouts",
]

#: Physics step of the scenes (s); a rate's step is the largest that divides its period.
BASE_SIM_DT = 0.002
#: Vector observation key -> LeRobot feature key (cameras: ``observation.images.<cam>``).
LEROBOT_KEYS: dict[str, str] = {
    "agent_pos": STATE_KEY,
    "velocity": VELOCITY_KEY,
    "environment_state": ENV_STATE_KEY,
}
#: Spawn key of the evaluation seed stream (``episode_generator``): ASCII "eval".
EVAL_STREAM = 0x6576616C
#: Camera rendered for videos when the policy observes none.
RENDER_CAMERA = "cam_high"


def episode_generator(seed: int) -> np.random.Generator:
    """The generator of evaluation episode ``seed``: ``SeedSequence(seed)`` spawned on the
    evaluation stream. ``record`` seeds with plain ints (``default_rng(int)``, no spawn
    key), so no evaluation episode shares a stream with a recorded one."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UserError(f"seed must be a non-negative int, got {seed!r}")
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(EVAL_STREAM,)))


def rate_timing(fps: float) -> dict[str, float]:
    """Config overrides that run a task at ``fps``: policy and control period 1/fps s, and a
    physics step that divides it (``BASE_SIM_DT`` or the largest below it)."""
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 1 <= fps <= 500):
        raise UserError(f"fps must be a number in [1, 500], got {fps!r}")
    period = 1.0 / float(fps)
    substeps = math.ceil(period / BASE_SIM_DT - 1e-9)
    return {"policy_dt": period, "ctrl_dt": period, "sim_dt": period / substeps}


def controller_timing(fps: float) -> dict[str, float]:
    """``rate_timing(fps)`` with the control period at the physics step: the driver's
    trajectory reaches the actuators every physics step, as on the served kit."""
    timing = rate_timing(fps)
    return {**timing, "ctrl_dt": timing["sim_dt"]}


def feature_spec(
    task: str, cam_names: Sequence[str], image_size: Sequence[int], layout: str = "kit14"
) -> dict[str, tuple[str, str, tuple[int, ...]]]:
    """What the env observes and takes, as LeRobot features: env key -> (LeRobot key, kind,
    shape), kind one of ``STATE``, ``ENV``, ``VISUAL``, ``ACTION``. Images are (H, W, 3)
    (``cam_names`` and ``image_size``: a ``CameraSettings``' ``names`` and ``size``). A
    single arm's task (layout ``widowxai``): ``eval.arm_env.arm_feature_spec``.

    Args:
        task: registered task name (or alias).
        cam_names: the observed cameras.
        image_size: (H, W) of each image, pixels.
        layout: ``kit14``, ``vendor16`` or ``mobileai``: the order and units of the vectors (rad;
            gripper m; base m/s, rad/s).
    """
    from trossen_arm_mujoco.eval.arm_tasks import is_arm_task

    if is_arm_task(task):
        from trossen_arm_mujoco.eval import arm_tasks

        return arm_tasks.arm_feature_spec(
            arm_tasks.arm_object_count(task),
            tuple(cam_names),
            image_size,
            goal=arm_tasks.arm_goal_conditioned(task),
        )
    size = _layout(layout).size
    n_obj = len(registry.load(task).task_class().objects)
    h, w = image_size
    spec: dict[str, tuple[str, str, tuple[int, ...]]] = {
        "action": (ACTION_KEY, "ACTION", (size,)),
        "agent_pos": (LEROBOT_KEYS["agent_pos"], "STATE", (size,)),
        "velocity": (LEROBOT_KEYS["velocity"], "STATE", (size,)),
        "environment_state": (LEROBOT_KEYS["environment_state"], "ENV", (7 * n_obj,)),
    }
    for cam in cam_names:  # keyed by the feature itself: lerobot-eval --eval.recording needs it
        key = image_key(cam)
        spec[key] = (key, "VISUAL", (h, w, 3))
    return spec


#: The layouts a Stationary AI kit policy may use (mobileai is the Mobile AI's).
KIT_LAYOUTS = ("kit14", "vendor16")


def _layout(name: str):
    if name not in KIT_LAYOUTS + MOBILE_LAYOUTS:
        raise unknown_name_error("layout", name, KIT_LAYOUTS + MOBILE_LAYOUTS)
    return LAYOUTS[name]


def task_layouts(task: str) -> tuple[str, ...]:
    """The layouts a policy of ``task`` may use, its default first: ``kit14``, ``vendor16``
    for a Stationary AI kit task, ``mobileai`` for a Mobile AI one, ``widowxai`` for a single
    arm's (``eval.arm_env``); a UserError naming the tasks eval takes for any other."""
    from trossen_arm_mujoco.eval.arm_tasks import ARM_LAYOUT_NAME, arm_names, is_arm_task

    entry = registry.load(task)
    if entry.name in registry.kit_names():
        return KIT_LAYOUTS
    if entry.name in mobile_names():
        return MOBILE_LAYOUTS
    if is_arm_task(entry.name):
        return (ARM_LAYOUT_NAME,)
    raise UserError(
        f"task '{entry.name}' is neither a Stationary AI kit, a Mobile AI nor a single-arm "
        f"task; valid tasks: {', '.join(registry.kit_names() + mobile_names() + arm_names())}"
    )


def episode_length_of(
    entry: Any, config: Mapping[str, Any], fps: float, native: float, asked: Any
) -> int:
    """Steps per evaluation episode: ``asked``, or the task's recording length (its
    ``TaskEntry.record`` ``episode_len``, else the config's ``max_episode_steps``, in steps
    at the ``native`` rate) at ``fps``; a value that is not a whole number in [1, 100000]
    is a one-line UserError."""
    if asked is None:
        record_len = int(entry.record.get("episode_len") or config.get("max_episode_steps"))
        asked = max(1, round(record_len * fps / native))
    if isinstance(asked, bool) or int(asked) != asked:
        raise UserError(f"episode_length must be a whole number, got {asked!r}")
    if not 1 <= int(asked) <= 100_000:
        raise UserError(f"episode_length must be in [1, 100000], got {asked}")
    return int(asked)


def _cameras(
    cameras: CameraSettings | None,
    cam_names: str | Sequence[str] | None,
    image_size: str | Sequence[int] | None,
    crops: str | Sequence[str] | None,
) -> CameraSettings:
    """``cameras``, or the settings of the three command-line values; both is a UserError."""
    loose = (cam_names, image_size, crops)
    if cameras is None:
        return CameraSettings.from_cli(*loose)
    if not isinstance(cameras, CameraSettings):
        raise UserError(
            f"cameras must be a CameraSettings (sim.camera_settings), got {type(cameras).__name__}"
        )
    if any(v is not None for v in loose):
        raise UserError(
            "give the cameras either as cameras=CameraSettings(...) or as "
            "cam_names / image_size / crops, not both"
        )
    return cameras


class KitPolicyEnv(gymnasium.Env):
    """A policy's view of a bimanual task (see the module docstring).

    Args:
        task_name: registered bimanual task name (or alias).
        cameras: what the cameras observe (``sim.camera_settings.CameraSettings``: the
            cameras of ``pixels``, their (H, W), the rectangle of its 480x640 frame each
            cropped camera shows, as they were recorded); default none (state only).
        cam_names, image_size, crops: the same, as the three values of the command line
            (``CameraSettings.from_cli``: camera names, (H, W) or ``"HxW"``, ``--crop``
            texts), for callers without a ``CameraSettings``; not with ``cameras``.
        fps: policy rate (steps per second); default the task's own (50).
        episode_length: steps per episode; default the task's recording length at this rate
            (12 s for the transfer, 8 s for the insertion).
        layout: ``kit14`` or ``vendor16`` (kit tasks), ``mobileai`` (Mobile AI tasks).
        render_mode: ``rgb_array`` (``render()`` gives the observed cameras side by side, or
            ``cam_high`` at 240x320 when none is observed) or None.
        controller_checks: apply the real arm controller's checks to every setpoint (a
            fault ends the episode, failed); False: the unconstrained score.
        randomize: each episode's scene randomized as the task's ``randomization`` section
            says (lights, table, colours, friction, masses, damping, camera poses, the arms'
            start), from the episode's seed: same seed, same scene. Default off (nominal).
        randomization: a ``randomization`` section (kinds and ranges, checked like the
            task's YAML) that replaces the task's; implies ``randomize``.

    Attributes (what LeRobot's evaluation reads): ``task_description`` (the task's
    instruction, LeRobot's ``task`` string), ``_max_episode_steps`` (``episode_length`` under
    the name LeRobot reads), ``metadata["render_fps"]``; ``task_name`` (the registered name),
    ``cameras`` (its ``CameraSettings``; ``cam_names`` and ``image_size`` read them);
    ``episode_length`` is the number of steps after which an episode is truncated (what this
    package's runners and adapters read); ``task`` is the running ``Task`` (None before the
    first reset); ``scene`` the world it runs in (``sim.scene.Scene``); ``controller`` is the kit's
    :class:`~trossen_arm_mujoco.real.arm_controller.KitController` (its ``fault`` and
    ``peak_fractions()`` describe the running episode).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        task_name: str = registry.DEFAULT_TASK,
        *,
        cameras: CameraSettings | None = None,
        fps: float | None = None,
        episode_length: int | None = None,
        layout: str = "kit14",
        render_mode: str | None = "rgb_array",
        controller_checks: bool = True,
        cam_names: str | Sequence[str] | None = None,
        image_size: str | Sequence[int] | None = None,
        crops: str | Sequence[str] | None = None,
        randomize: bool = False,
        randomization: Mapping[str, Any] | None = None,
    ):
        entry = registry.load(task_name)
        valid = task_layouts(entry.name)
        if layout not in valid:
            raise UserError(
                f"task '{entry.name}' takes the layouts {', '.join(valid)}, not "
                f"{layout!r} (--layout)"
            )
        self.layout = _layout(layout)
        self.layout_name = layout
        if render_mode not in (None, "rgb_array"):
            raise unknown_name_error("render mode", str(render_mode), ["rgb_array"])
        self.render_mode = render_mode
        self.cameras = _cameras(cameras, cam_names, image_size, crops)
        config = entry.load_config()
        native = 1.0 / float(config["policy_dt"])
        self.fps = float(native if fps is None else fps)
        overrides: dict[str, Any] = dict(controller_timing(self.fps))
        self.randomize = bool(randomize) or randomization is not None
        if randomization is not None:
            overrides[RANDOMIZATION_KEY] = dict(randomization)
        episode_length = episode_length_of(entry, config, self.fps, native, episode_length)
        self.task_name = entry.name
        cams = self.cameras
        settings = SamplerSettings(
            camera_names=cams.names,
            height=cams.size[0],
            width=cams.size[1],
            looks=cams.scene_looks(),
            randomize=self.randomize,
        )
        self.sampler = registry.make_sampler(entry.name, settings, **overrides)
        self.scene = self.sampler.scene
        probe = self.sampler.make_task()
        self.task_description = probe.get_task_description()
        self.max_reward = float(probe.max_reward)
        self.episode_length = int(episode_length)
        self.metadata = {**self.metadata, "render_fps": self.fps}
        view = self.scene.robots[probe.robot_name].view
        ranges = np.concatenate(
            [view.get_move_group(g).joint_range for g in VENDOR16_LAYOUT.groups]
        )
        low16, high16 = ranges[:, 0], ranges[:, 1]
        robot = self.scene.robots[probe.robot_name]
        self.base = MobileBase(robot, controller_checks) if valid == MOBILE_LAYOUTS else None
        if self.layout is KIT14_LAYOUT:
            self.action_low = KIT14_LAYOUT.from_vendor(low16)
            self.action_high = KIT14_LAYOUT.from_vendor(high16)
        elif self.base is not None:  # the arms' 14, then the base's limits
            b_low, b_high = self.base.action_bounds()
            self.action_low = np.concatenate([KIT14_LAYOUT.from_vendor(low16), b_low])
            self.action_high = np.concatenate([KIT14_LAYOUT.from_vendor(high16), b_high])
        else:
            self.action_low, self.action_high = low16.copy(), high16.copy()
        self.action_space = gymnasium.spaces.Box(
            self.action_low.astype(np.float32),
            self.action_high.astype(np.float32),
            dtype=np.float32,
        )
        self.observation_space = self._observation_space(probe)
        self._vector_bounds = {
            key: (self.observation_space[key].low, self.observation_space[key].high)
            for key in ("agent_pos", "velocity", "environment_state")
        }
        self.controller = KitController(checks=controller_checks)
        self.controller_checks = bool(controller_checks)
        self._goal_time = GOAL_TIME_FACTOR / self.fps
        self._ticks = int(probe.n_ctrl_steps)
        self._tick_dt = float(overrides["ctrl_dt"])
        self._reached = False
        self.task = None
        self.n_steps = 0
        self._images: dict[str, np.ndarray] = {}
        self._render_cams: CameraSet | None = None
        close_at_exit(self)

    @property
    def cam_names(self) -> tuple[str, ...]:
        """The observed cameras (``cameras.names``)."""
        return self.cameras.names

    @property
    def image_size(self) -> tuple[int, int]:
        """(H, W) of the observed images, pixels (``cameras.size``)."""
        return self.cameras.size

    # -- spaces ---------------------------------------------------------------------------
    def _observation_space(self, probe) -> gymnasium.spaces.Dict:
        bounds = probe.observation_bounds()
        size = self.layout.size
        base = None if self.base is None else MobileBase.observation_bounds(bounds)

        def box(key: str) -> gymnasium.spaces.Box:
            low, high = (self._to_layout(b) for b in bounds[key])
            if base is not None:  # the measured base velocities after the arms' 14
                low, high = np.concatenate([low, base[0]]), np.concatenate([high, base[1]])
            return gymnasium.spaces.Box(
                low.astype(np.float32), high.astype(np.float32), shape=(size,), dtype=np.float32
            )

        spaces: dict[str, gymnasium.spaces.Space] = {
            "agent_pos": box("qpos"),
            "velocity": box("qvel"),
            "environment_state": gymnasium.spaces.Box(
                *(b.astype(np.float32) for b in bounds["env_state"]), dtype=np.float32
            ),
        }
        if self.cam_names:
            h, w = self.image_size
            spaces["pixels"] = gymnasium.spaces.Dict(
                {
                    cam: gymnasium.spaces.Box(0, 255, (h, w, 3), dtype=np.uint8)
                    for cam in self.cam_names
                }
            )
        return gymnasium.spaces.Dict(spaces)

    def _to_layout(self, values16: np.ndarray) -> np.ndarray:
        """The arms' vendor16 values in the env's layout (``mobileai``: their kit14 part)."""
        if self.layout is KIT14_LAYOUT or self.layout is MOBILEAI_LAYOUT:
            return KIT14_LAYOUT.from_vendor(values16)
        return np.asarray(values16)

    # -- gymnasium API --------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; ``seed`` picks it (see ``episode_generator``); None draws one
        from the env's own generator.

        ``options={"object_poses": {name: pose}}`` places the named objects instead of the
        sampled poses (e.g. a recorded episode's start: the HDF5 attributes
        ``object_names`` and ``initial_env_state``), each pose 7 values [xyz m, quat wxyz];
        objects not named keep their sampled pose. Any other option (but the keys of
        ``gym.inputs.WRAPPER_OPTIONS``, such as lerobot-eval's ``lerobot_new_rollout``), an
        unknown object or a bad pose is a ``UserError`` (``gym.inputs.InvalidInput``).
        """
        poses = reset_options(options, self.scene.objects)
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(2**31))
        rng = episode_generator(seed)
        self.task = self.sampler.next_task(rng, object_poses=poses)
        self.n_steps = 0
        self._reached = False
        obs = self._observe()
        measured = (
            obs["agent_pos"][:14]
            if self.layout is not VENDOR16_LAYOUT
            else (KIT14_LAYOUT.from_vendor(obs["agent_pos"]))
        )
        self.controller.reset(measured.astype(np.float64))
        if self.base is not None:
            self.base.reset()
        return obs, self._info(self.task.get_reward())

    def step(self, action):
        if self.task is None:
            raise UserError("call reset() before step()")
        a = np.array(action, dtype=float).reshape(-1)
        if a.shape != (self.layout.size,):
            raise UserError(
                f"action must have {self.layout.size} values (layout {self.layout_name}), "
                f"got shape {np.shape(action)}"
            )
        if not self.controller_checks and not np.isfinite(a).all():
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        goal = (
            a
            if self.layout is KIT14_LAYOUT
            else (a[:14] if self.base is not None else KIT14_LAYOUT.from_vendor(a))
        )
        ctl, task, scene = self.controller, self.task, self.scene
        base, base_fault = ({}, None) if self.base is None else self.base.command(a, self.n_steps)
        ctl.command(goal, self._goal_time)
        fault = None
        for _ in range(self._ticks if base_fault is None else 0):
            target, fault = ctl.tick(self._tick_dt)
            if fault is not None:  # the arms stop in the error state: the episode ends
                break
            commands = KIT14_LAYOUT.joint_commands(target)
            if base:  # once a step: the base's command holds until the next
                commands.update(base)
                base = {}
            task.apply_action(commands)
            scene.step(1)
        task.finish_step()
        self.n_steps += 1
        reward = float(task.get_reward())
        self._reached = self._reached or reward >= self.max_reward
        truncated = self.n_steps >= self.episode_length
        info = self._info(reward, last=truncated or fault is not None or base_fault is not None)
        if fault is not None:
            info["fault"] = {**fault.as_dict(), "step": self.n_steps - 1}
        if base_fault is not None:
            info["fault"] = base_fault
        if self.base is not None:
            info["base_clipped"] = self.base.clipped
        done = fault is not None or base_fault is not None
        return self._observe(), reward, done, truncated, info

    def render(self):
        """The observed cameras side by side (uint8 (H, n*W, 3)), or ``cam_high`` at
        240x320 when none is observed."""
        if self.render_mode != "rgb_array" or self.task is None:
            return None
        if self.cam_names:  # the images of the last observation
            return np.concatenate([self._images[c] for c in self.cam_names], axis=1)
        if self._render_cams is None:
            self._render_cams = CameraSet(self.scene.model, [RENDER_CAMERA], 240, 320)
        return self._render_cams.render(self.scene.data, RENDER_CAMERA)

    def close(self):
        forget(self)
        if self._render_cams is not None:
            self._render_cams.close()
            self._render_cams = None
        self.sampler.close()

    @property
    def _max_episode_steps(self) -> int:
        """``episode_length``, under the name LeRobot's evaluation reads
        (``env.call("_max_episode_steps")``); this package reads ``episode_length``."""
        return self.episode_length

    def get_wrapper_attr(self, name: str) -> Any:
        """As gymnasium's, but ``task`` through a vector env (``get_attr``, ``call``) is the
        task's name: LeRobot's evaluation reads a string ``task`` there, and the running
        ``Task`` does not pickle out of an async worker."""
        return self.task_name if name == "task" else super().get_wrapper_attr(name)

    # -- what a policy reads --------------------------------------------------------------
    def object_poses(self) -> dict[str, np.ndarray]:
        """Object name -> current pose (7,) (e.g. for the scripted reference)."""
        return self.task.object_poses()

    def _observe(self) -> dict[str, Any]:
        obs = self.task.get_observation()
        out: dict[str, Any] = {
            "agent_pos": self._to_layout(obs["qpos"]).astype(np.float32),
            "velocity": self._to_layout(obs["qvel"]).astype(np.float32),
            "environment_state": obs["env_state"].astype(np.float32),
        }
        if self.base is not None:  # mobileai: the arms' 14 values, then the base's measured
            state, velocity = self.task.recorded_state()
            out["agent_pos"], out["velocity"] = (v.astype(np.float32) for v in (state, velocity))
        for key, (low, high) in self._vector_bounds.items():  # e.g. a finger 0.1 mm past
            clip(out[key], low, high, out=out[key])  # its limit: inside the space, as gym's
        if self.cam_names:
            self._images = self.scene.render_images()
            out["pixels"] = self._images
        return out

    @property
    def randomization(self) -> dict[str, Any] | None:
        """What the running episode's scene was randomized by (``tasks.randomization``'s
        record; None: the nominal scene)."""
        return self.sampler.randomization if self.randomize else None

    def _info(self, reward: float, last: bool = False) -> dict[str, Any]:
        if self.controller_checks:  # judged once the episode is over: no fault, then success
            success = last and self._reached and self.controller.fault is None
        else:
            success = reward >= self.max_reward
        return {"is_success": bool(success), "stage": float(reward)}
