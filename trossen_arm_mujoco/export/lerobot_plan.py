"""Which episodes a LeRobot export holds and which source values make each written frame,
checked before anything is written.

All episodes must share the frame rate, the cameras and their image sizes, the objects of
``env_state``, and either all have rewards or none (vendor recordings). The rate written is
``fps`` N (default :data:`DEFAULT_FPS`, 30, or the recording rate F when lower). Frame ``k``
is at ``t_k = k / N``: observations are the source interpolated at ``t_k``, images the
nearest source frame, the action the source action trajectory at ``t_k + 1/N - 1/F``, reward
and success those of the step whose period holds ``t_{k+1}``. ``T`` steps give
``floor(T N / F)`` frames; at ``N = F`` every frame is its source step, bit for bit.

Docs: docs/datasets.md (resampling); the full rule: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.data.schema import ENV_STATE_DIM
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.export.dataset_settings import DatasetSettings
from trossen_arm_mujoco.export.goal_state import GOAL_NAMES, GoalJudge, episode_goal, goal_judge
from trossen_arm_mujoco.export.lerobot_state import check_state_extras
from trossen_arm_mujoco.robot.layout import EXPORT_LAYOUTS
from trossen_arm_mujoco.sim.camera_crop import CameraCrop, parse_crops
from trossen_arm_mujoco.sim.camera_settings import DEFAULT_SIZE, CameraSettings
from trossen_arm_mujoco.tasks import registry

__all__ = [
    "BASE_ACTIONS",
    "DEFAULT_FPS",
    "DEFAULT_LAYOUT",
    "POSE_COMPONENTS",
    "ExportPlan",
    "FrameMap",
    "check_base_action",
    "check_layout",
    "env_state_names",
    "episode_frames",
    "frame_map",
    "output_fps",
    "plan_export",
    "recorded_layout",
    "resolve_layout",
    "source_fps",
]

#: The layout written unless asked otherwise: the real kit's 14 values (the Mobile AI's
#: recordings: ``mobileai``, ``resolve_layout``).
DEFAULT_LAYOUT = "kit14"
MOBILEAI, VENDOR16, WIDOWXAI = "mobileai", "vendor16", "widowxai"
#: Export layouts per recorded layout, the default first.
_FITTING: dict[str, tuple[str, ...]] = {
    VENDOR16: (DEFAULT_LAYOUT, VENDOR16),
    MOBILEAI: (MOBILEAI,),
    WIDOWXAI: (WIDOWXAI,),
}
#: The rate written unless asked otherwise: Trossen's LeRobot plugin's ``loop_rate`` (Hz).
DEFAULT_FPS = 30
#: What the Mobile AI's action holds for the base: its measured velocity (``lerobot-record``
#: with the plugin's teleoperator, the default) or the recorded command.
BASE_ACTIONS: tuple[str, ...] = ("measured", "commanded")
#: Suffixes of an object's 7 pose values in ``observation.environment_state`` names.
POSE_COMPONENTS: tuple[str, ...] = ("x", "y", "z", "qw", "qx", "qy", "qz")


@dataclass
class ExportPlan:
    """Checked facts about the episodes to export.

    Attributes:
        episodes: in export order (episode_index 0, 1, ...).
        fps: frames per second written; source_fps: the recording rate, ``1 / dt``.
        cameras: camera names in recording order; image_shapes: ``{camera: (H, W, 3)}``.
        with_reward: the episodes have rewards (``next.reward`` / ``next.success``).
        tasks: distinct task descriptions, in ``task_index`` order.
        task_index: per episode, its task's index.
        max_reward: per episode, the reward that means success (None without rewards).
        layout: the joint layout written, a key of ``robot.layout.EXPORT_LAYOUTS``.
        env_names: names of the ``observation.environment_state`` values (None: the
            episodes have no env_state).
        lengths: per episode, the frames written.
        state_extras: per-joint values added to ``observation.state`` after each arm's
            positions, in the LeRobot plugin's order: ``"vel"``, ``"eff"``, ``"ext_eff"``
            (``.lerobot_state``).
        sim_features: write the simulation's additions (``observation.velocity``,
            ``observation.environment_state``, ``next.reward``, ``next.success``).
        base_action: the Mobile AI's base action, one of :data:`BASE_ACTIONS` (None for
            the other layouts).
        goal_judges: per episode, how its goal-conditioned task judges ``next.success``
            from the object poses (``export.goal_state``; None: by ``max_reward``).
    """

    episodes: list[Episode]
    fps: int
    cameras: list[str]
    image_shapes: dict[str, tuple[int, int, int]]
    with_reward: bool
    tasks: list[str]  # distinct descriptions, task_index order
    task_index: list[int]  # per episode
    max_reward: list[float | None]  # per episode
    source_fps: int
    layout: str
    env_names: list[str] | None
    lengths: list[int]  # per episode
    crops: tuple[CameraCrop, ...] = ()  # the episodes' ``crops`` attribute (record --crop)
    looks: tuple[bool, bool] = (True, True)  # the episodes' (shadows, antialias) attributes
    task_name: str | None = None  # the registered task of the episodes, when they name one
    state_extras: tuple[str, ...] = ()  # "vel", "eff", "ext_eff": added to observation.state
    sim_features: bool = False
    base_action: str | None = None
    goal_judges: list[GoalJudge | None] | None = None  # per episode (None: none judged)

    def settings(self) -> DatasetSettings:
        """What the dataset is made with (``export.dataset_settings``), for its info.json."""
        shapes = list(self.image_shapes.values())
        cameras = CameraSettings(
            names=tuple(self.cameras),
            size=(int(shapes[0][0]), int(shapes[0][1])) if shapes else DEFAULT_SIZE,
            crops=self.crops,
            shadows=self.looks[0],
            antialias=self.looks[1],
        )
        return DatasetSettings(
            fps=int(self.fps),
            layout=self.layout,
            cameras=cameras,
            task=self.task_name,
            state_extras=self.state_extras,
            sim_features=self.sim_features,
            base_action=self.base_action,
        )


@dataclass(frozen=True)
class FrameMap:
    """Which source steps make the written frames of one episode (module docstring).

    Frame ``k``'s observations are ``(1 - f) x[j] + f x[j + 1]`` with ``j = obs_index[k]``
    and ``f = obs_frac[k]``, its action likewise with ``action_index`` / ``action_frac``;
    its images are source frame ``image_index[k]``, its reward source step
    ``reward_index[k]``.
    """

    num_steps: int
    obs_index: np.ndarray
    obs_frac: np.ndarray
    action_index: np.ndarray
    action_frac: np.ndarray
    image_index: np.ndarray
    reward_index: np.ndarray

    @property
    def length(self) -> int:
        """Frames written."""
        return int(self.obs_index.shape[0])

    def observations(self, values: np.ndarray) -> np.ndarray:
        """``(T, D)`` source observations at the written frames (float64)."""
        return _lerp(values, self.obs_index, self.obs_frac)

    def actions(self, values: np.ndarray) -> np.ndarray:
        """``(T, D)`` source actions at the written frames (float64)."""
        return _lerp(values, self.action_index, self.action_frac)

    def poses(self, values: np.ndarray) -> np.ndarray:
        """``(T, 7k)`` object poses (xyz + quat wxyz each) at the written frames (float64)."""
        v = np.asarray(values, dtype=np.float64)
        j0, j1 = self.obs_index, np.minimum(self.obs_index + 1, self.num_steps - 1)
        a, b = v[j0].reshape(len(j0), -1, 7), v[j1].reshape(len(j0), -1, 7).copy()
        flip = np.sum(a[..., 3:] * b[..., 3:], axis=-1) < 0  # take the shorter way round
        b[..., 3:][flip] *= -1.0
        f = self.obs_frac[:, None, None]
        out = (1.0 - f) * a + f * b
        moved = self.obs_frac > 0  # source rows keep their exact values
        quat = out[moved, :, 3:]
        out[moved, :, 3:] = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
        return out.reshape(len(j0), -1)


def _lerp(values: np.ndarray, index: np.ndarray, frac: np.ndarray) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64)
    after = np.minimum(index + 1, v.shape[0] - 1)
    f = frac.reshape((-1,) + (1,) * (v.ndim - 1))
    return (1.0 - f) * v[index] + f * v[after]


def frame_map(num_steps: int, source_fps: int, fps: int) -> FrameMap:
    """The frames an episode gives at ``fps``; exact integer arithmetic throughout.

    Args:
        num_steps: the episode's recorded steps ``T``.
        source_fps: the recording rate F (steps per second).
        fps: the rate written N, ``1 <= fps <= source_fps``.

    Returns:
        The :class:`FrameMap` of the ``floor(T N / F)`` frames.
    """
    big_f, n = int(source_fps), int(fps)
    length = num_steps * n // big_f
    k = np.arange(length, dtype=np.int64)
    obs = k * big_f  # source index k F / N = obs / N
    act = (k + 1) * big_f  # source index (k + 1) F / N - 1 = act / N - 1
    return FrameMap(
        num_steps=int(num_steps),
        obs_index=obs // n,
        obs_frac=(obs % n) / n,
        action_index=act // n - 1,
        action_frac=(act % n) / n,
        image_index=(2 * obs + n - 1) // (2 * n),  # nearest, ties down: ceil(s - 1/2)
        reward_index=-(-act // n) - 1,  # ceil((k + 1) F / N) - 1
    )


def output_fps(requested: Real | str | None, source_fps: int) -> int:
    """The rate to write: ``requested`` (a whole number in ``1 .. source_fps``; a string from
    the command line is parsed), or when None :data:`DEFAULT_FPS` (``source_fps`` if lower).

    Raises:
        UserError: not a whole number, not positive, or above the recording rate.
    """
    if requested is None:
        return min(DEFAULT_FPS, int(source_fps))
    value: object = requested
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            value = None
    whole = (
        isinstance(value, Real)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and float(value).is_integer()
    )
    if not whole:
        raise UserError(f"--fps must be a whole number of frames per second, got '{requested}'")
    fps = int(value)
    if fps <= 0:
        raise UserError(f"--fps must be at least 1, got {fps}")
    if fps > source_fps:
        raise UserError(
            f"--fps {fps} is above the recording rate ({source_fps} frames/s); frames are "
            f"resampled, never invented: use --fps {source_fps} or less"
        )
    return fps


def episode_frames(episode: Episode, fps: Real | str | None = None) -> FrameMap:
    """The :class:`FrameMap` of ``episode`` written at ``fps`` (None: the default,
    :func:`output_fps`).

    Raises:
        UserError: a bad ``fps`` (:func:`output_fps`), or an episode too short to give one
            frame at it.
    """
    rate = source_fps(episode)
    out_fps = output_fps(fps, rate)
    frames = frame_map(episode.num_steps, rate, out_fps)
    if frames.length < 1:
        raise UserError(
            f"{episode.path.name} has {episode.num_steps} step(s), too short for --fps "
            f"{out_fps} (needs at least {math.ceil(rate / out_fps)} at {rate} frames/s)"
        )
    return frames


def check_layout(layout: str) -> str:
    """``layout`` if it names a layout of ``robot.layout.EXPORT_LAYOUTS``, else a UserError."""
    if layout not in EXPORT_LAYOUTS:
        raise unknown_name_error("layout", str(layout), EXPORT_LAYOUTS)
    return layout


def source_fps(episode: Episode) -> int:
    """The recording rate of ``episode``, ``1 / dt``, a whole number (UserError if not, and
    for a ``dt`` that is not a positive number: zero, negative, NaN, infinite, text)."""
    try:
        dt = float(episode.dt)
    except (TypeError, ValueError):
        dt = math.nan
    if not (math.isfinite(dt) and dt > 0):
        raw = episode.attrs.get("dt")
        shown = repr(raw) if isinstance(raw, str | bytes) else f"{dt:g}"
        raise UserError(
            f"{episode.path.name}: step period dt={shown} is not a positive number of seconds; "
            "fix the file's 'dt' attribute (50 frames/s is dt=0.02)"
        )
    rate = 1.0 / dt
    fps = round(rate)
    if fps < 1 or abs(rate - fps) > 1e-6 * rate:
        raise UserError(
            f"{episode.path.name}: step period dt={dt:g} s gives {rate:g} frames/s; "
            "LeRobot datasets need a whole number of frames per second"
        )
    return fps


def _object_names(episode: Episode) -> list[str]:
    """The episode's objects in env_state order: its ``object_names`` attribute, else
    ``obj0``, ``obj1``... (none without env_state)."""
    if episode.env_state is None:
        return []
    count = episode.env_state.shape[1] // ENV_STATE_DIM
    objects = episode.attrs.get("object_names")
    objects = [objects] if isinstance(objects, str) else objects
    if not (
        isinstance(objects, list)
        and len(objects) == count
        and all(isinstance(o, str) and o for o in objects)
    ):
        objects = [f"obj{i}" for i in range(count)]
    return list(objects)


def env_state_names(episode: Episode) -> list[str] | None:
    """Names of the episode's env_state values, ``<object>_x`` .. ``<object>_qz`` per object
    (objects from the ``object_names`` attribute, else ``obj0``, ``obj1``...), then
    ``goal_x``, ``goal_y``, ``goal_z`` for a goal-conditioned episode (``export.goal_state``);
    None without env_state."""
    if episode.env_state is None:
        return None
    names = [f"{obj}_{part}" for obj in _object_names(episode) for part in POSE_COMPONENTS]
    return names + (list(GOAL_NAMES) if episode_goal(episode) is not None else [])


def recorded_layout(episode: Episode) -> str:
    """The layout of an episode's rows: its ``layout`` attribute (``mobileai`` for the Mobile
    AI's recordings, ``collect.joint_policy``; ``widowxai`` for a single arm's), else
    ``vendor16``."""
    value = episode.attrs.get("layout", VENDOR16)
    return value.decode() if isinstance(value, bytes) else str(value)


def resolve_layout(episodes: list[Episode], layout: str | None) -> str:
    """The layout to write: ``layout``, or (None) the one that fits the episodes: ``mobileai``
    for Mobile AI recordings, ``widowxai`` for a single arm's, else ``kit14``. A UserError
    for episodes recorded in different layouts, and for a layout that does not fit them (the
    Mobile AI's and a single arm's values export only in their own layout; the kit's as
    ``kit14`` or ``vendor16``)."""
    recorded = {recorded_layout(ep) for ep in episodes}
    if len(recorded) > 1:
        raise UserError(
            f"the episodes are recorded in different layouts ({', '.join(sorted(recorded))}); "
            "export each robot's episodes separately"
        )
    stored = recorded.pop()
    if stored not in _FITTING:
        raise unknown_name_error(f"{episodes[0].path.name}: recorded layout", stored, _FITTING)
    fits = _FITTING[stored]
    if layout is None:
        return fits[0]
    check_layout(layout)
    if layout not in fits:
        robot = {MOBILEAI: "the Mobile AI", WIDOWXAI: "one WidowX AI arm"}.get(
            stored, "the Stationary AI kit"
        )
        raise UserError(
            f"--layout {layout} does not fit episodes recorded in the {stored} layout "
            f"({robot}); use --layout {' or '.join(fits)} or leave the flag out"
        )
    return layout


def check_base_action(layout: str, base_action: str | None) -> str | None:
    """The base action to write: None for layouts without a base (a UserError when one is
    asked for), else ``base_action`` (None: ``measured``), one of :data:`BASE_ACTIONS`."""
    if layout != MOBILEAI:
        if base_action not in (None, "measured"):
            raise UserError(
                f"--base_action {base_action} is for Mobile AI recordings (layout mobileai); "
                f"the {layout} layout has no base: leave the flag out"
            )
        return None
    if base_action is None:
        return BASE_ACTIONS[0]
    if base_action not in BASE_ACTIONS:
        raise unknown_name_error("base action", str(base_action), BASE_ACTIONS)
    return base_action


def plan_export(
    episodes: list[Episode],
    task: str | None,
    layout: str | None = None,
    fps: Real | str | None = None,
    state_extras: tuple[str, ...] = (),
    sim_features: bool = False,
    base_action: str | None = None,
) -> ExportPlan:
    """Check ``episodes`` for export and decide what each written frame holds.

    Args:
        episodes: the episodes to export, at least one, in dataset order.
        task: a description for every episode (None: each task's from the registry).
        layout: the joint layout written (None: the one that fits the episodes,
            ``resolve_layout``).
        fps: the rate written, frames per second (None: :data:`DEFAULT_FPS`, or the
            recording rate if lower).
        state_extras: per-joint values added to the state (``"vel"``, ``"eff"``,
            ``"ext_eff"``; the plugin's layouts only).
        sim_features: add the simulation's features (velocity, environment state, reward,
            success).
        base_action: the Mobile AI's base action, ``measured`` or ``commanded`` (None:
            ``measured``).

    Returns:
        The :class:`ExportPlan`.

    Raises:
        UserError: mixed rates, cameras, rewards, objects or layouts; no task to describe an
            episode with; an unknown layout or one that does not fit; a bad ``fps``; an
            episode too short for ``fps``; a base action for a layout without a base.
    """
    layout = resolve_layout(episodes, layout)
    state_extras = check_state_extras(layout, state_extras)
    base_action = check_base_action(layout, base_action)
    first = episodes[0]
    rate = source_fps(first)
    out_fps = output_fps(fps, rate)
    env_names = env_state_names(first)
    tasks: list[str] = []
    task_index: list[int] = []
    max_reward: list[float | None] = []
    judges: list[GoalJudge | None] = []
    lengths: list[int] = []
    for ep in episodes:
        if source_fps(ep) != rate:
            raise UserError(
                f"{ep.path.name} runs at {source_fps(ep)} frames/s but {first.path.name} at "
                f"{rate}; export episodes of one rate together"
            )
        if ep.camera_names != first.camera_names or ep.image_shapes != first.image_shapes:
            raise UserError(
                f"{ep.path.name} has cameras {_describe_cams(ep)} but {first.path.name} has "
                f"{_describe_cams(first)}; every episode of a dataset needs the same cameras"
            )
        if (ep.reward is None) != (first.reward is None):
            has, lacks = (ep, first) if first.reward is None else (first, ep)
            raise UserError(
                f"{has.path.name} has rewards but {lacks.path.name} has none (a vendor "
                "recording?); export them separately"
            )
        if _crops(ep) != _crops(first):
            raise UserError(
                f"{ep.path.name} was recorded with --crop {_crops(ep) or 'none'} but "
                f"{first.path.name} with {_crops(first) or 'none'}; every episode of a dataset "
                "needs the same crops"
            )
        if _looks(ep) != _looks(first):
            raise UserError(
                f"{ep.path.name} was drawn with {_describe_looks(ep)} but {first.path.name} "
                f"with {_describe_looks(first)}; every episode of a dataset needs the same "
                "--no_shadows and --no_antialias"
            )
        if env_state_names(ep) != env_names:
            raise UserError(
                f"{ep.path.name} has env_state {_describe_env(ep)} but {first.path.name} has "
                f"{_describe_env(first)}; export episodes with the same objects together"
            )
        lengths.append(episode_frames(ep, out_fps).length)
        name = ep.attrs.get("task_name")
        entry = registry.load(name) if isinstance(name, str) and name else None
        if task is None and entry is None:
            raise UserError(
                f"{ep.path.name} has no task_name attribute (a vendor recording?); "
                "describe the task with --task 'what the robot does'"
            )
        text = task if task is not None else entry.description
        if text not in tasks:
            tasks.append(text)
        task_index.append(tasks.index(text))
        if ep.reward is not None and entry is None:
            raise UserError(
                f"{ep.path.name} has rewards but no task_name to judge success with; "
                f"valid task names: {', '.join(registry.names())}"
            )
        best = _max_reward(entry)
        judge = goal_judge(entry, _object_names(ep)) if episode_goal(ep) is not None else None
        judges.append(judge)
        if sim_features and ep.reward is not None and best is None and judge is None:
            raise UserError(
                f"{ep.path.name}: task {entry.name} has no maximum reward to judge next.success "
                "with; export it without --sim_features"
            )
        max_reward.append(best)
    return ExportPlan(
        episodes=episodes,
        fps=out_fps,
        cameras=list(first.camera_names),
        image_shapes={cam: first.image_shapes[cam] for cam in first.camera_names},
        with_reward=first.reward is not None,
        tasks=tasks,
        task_index=task_index,
        max_reward=max_reward,
        source_fps=rate,
        layout=layout,
        env_names=env_names,
        lengths=lengths,
        crops=_parsed_crops(first),
        looks=_looks(first),
        task_name=_task_name(episodes),
        state_extras=state_extras,
        sim_features=bool(sim_features),
        base_action=base_action,
        goal_judges=judges,
    )


def _max_reward(entry: registry.TaskEntry | None) -> float | None:
    """The reward that means success for a registered task (None: no task, or a task that
    does not declare one)."""
    if entry is None:
        return None
    try:
        return float(entry.task_class().max_reward)
    except (AttributeError, TypeError):
        return None


def _crops(ep: Episode) -> str:
    """An episode's ``crops`` attribute (``;``-joined ``--crop`` texts; "" for none)."""
    value = ep.attrs.get("crops", "")
    return value.decode() if isinstance(value, bytes) else str(value or "")


def _looks(ep: Episode) -> tuple[bool, bool]:
    """An episode's ``(shadows, antialias)`` attributes (files without them: both on)."""
    return (bool(ep.attrs.get("shadows", True)), bool(ep.attrs.get("antialias", True)))


def _describe_looks(ep: Episode) -> str:
    shadows, antialias = _looks(ep)
    return f"shadows {'on' if shadows else 'off'}, antialiasing {'on' if antialias else 'off'}"


def _parsed_crops(ep: Episode) -> tuple[CameraCrop, ...]:
    """An episode's crops, parsed once here (a one-line UserError naming the file)."""
    try:
        return parse_crops(_crops(ep))
    except UserError as exc:
        raise UserError(f"{ep.path.name}: its crops attribute is unreadable ({exc})") from None


def _task_name(episodes: list[Episode]) -> str | None:
    """The registered task all ``episodes`` name, or None when they do not share one."""
    names = {ep.attrs.get("task_name") for ep in episodes}
    name = names.pop() if len(names) == 1 else None
    if not isinstance(name, str) or not name:
        return None
    try:
        return registry.load(name).name
    except UserError:
        return None


def _describe_cams(ep: Episode) -> str:
    cams = [f"{cam} {h}x{w}" for cam, (h, w, _) in ep.image_shapes.items()]
    return "[" + ", ".join(cams) + "]" if cams else "none"


def _describe_env(ep: Episode) -> str:
    names = env_state_names(ep)
    if names is None:
        return "none"
    parts = _object_names(ep) + (["goal"] if episode_goal(ep) is not None else [])
    return f"of {len(names)} values ({', '.join(parts)})"
