"""The values a LeRobot export writes per frame, before any encoding.

State, velocity and action in the written layout (``lerobot_format.layout_values``), the
actions as the arm controller executes them (:func:`controller_actions`), the objects'
poses, rewards and, per frame, the source step whose images it shows; resampled to the
written rate as ``lerobot_plan`` says (``FrameMap``). :func:`frame_values` gives them for one
episode, the simulation's additions included (what tests and the open-loop parity check
compare against); :func:`frame_columns` the columns of a dataset's parquet rows, the
simulation's additions only with the plan's ``sim_features``.

Docs: docs/datasets.md (The LeRobot export).
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export.goal_state import episode_goal
from trossen_arm_mujoco.export.lerobot_plan import (
    MOBILEAI,
    ExportPlan,
    FrameMap,
    check_base_action,
    episode_frames,
    frame_map,
    recorded_layout,
    resolve_layout,
)
from trossen_arm_mujoco.export.lerobot_state import state_source
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT, SIDES, WIDOWXAI_LAYOUT
from trossen_arm_mujoco.robot.lerobot_keys import ACTION_KEY, ENV_STATE_KEY, STATE_KEY, VELOCITY_KEY

__all__ = ["controller_actions", "frame_columns", "frame_values"]


def frame_values(
    episode: Episode,
    layout: str | None = None,
    fps: int | None = None,
    extras: tuple[str, ...] = (),
    base_action: str | None = None,
) -> dict[str, np.ndarray]:
    """What an export writes for ``episode`` per frame, before any encoding.

    Args:
        episode: the HDF5 episode, read.
        layout: the joint layout written (None: the one that fits the episode,
            ``lerobot_plan.resolve_layout``).
        fps: the rate written (None: the export's default, ``lerobot_plan.output_fps``).
        extras: per-joint values added to the state (``"vel"``, ``"eff"``, ``"ext_eff"``;
            ``lerobot_state.state_names``).
        base_action: the Mobile AI's base action, ``measured`` or ``commanded`` (None:
            ``measured``).

    Returns:
        ``observation.state``, ``action``: float32 ``(K, D)`` in ``layout``; the simulation's
        additions (written with ``sim_features``): ``observation.velocity`` float32
        ``(K, D)``, ``observation.environment_state`` float32 ``(K, 7k)`` (episodes with
        env_state), ``next.reward`` float32 ``(K,)`` (episodes with rewards);
        ``image_index``: int64 ``(K,)``, the source step whose images frame ``k`` shows.
        ``K`` frames at ``fps`` (None: the export's default, ``lerobot_plan.output_fps``);
        see ``export.lerobot``'s docstring. ``extras`` (``"vel"``, ``"eff"``, ``"ext_eff"``)
        widen the state (``lerobot_state.state_names``). ``layout`` None: the one that fits
        the episode (``lerobot_plan.resolve_layout``); ``base_action``: the Mobile AI's
        (None: ``measured``).

    Raises:
        UserError: an unknown layout or one that does not fit the episode, a bad ``fps``,
            an episode too short for ``fps``, a base action without a base.
    """
    layout = resolve_layout([episode], layout)
    base_action = check_base_action(layout, base_action)
    return _values(episode, layout, episode_frames(episode, fps), extras, base_action)


#: The finger values of the HDF5 files' 16 (left 6, 7; right 14, 15).
_FINGERS = [6, 7, 14, 15]


def controller_actions(action16: np.ndarray, recorded: str = "vendor16") -> np.ndarray:
    """The recorded actions ``(T, 16)`` as the arm controller executes them: each gripper
    at most ``GRIPPER_MAX`` (0.04 m per finger; the controller clips the recorder's fully
    open 0.044 m to it). A policy learns the opening the arm reaches, and its own small
    errors around it stay inside the controller's 0.044 + 0.001 m position check (around
    0.044 they do not: about half its open-gripper actions would fault). ``recorded``: the
    layout of the rows (``vendor16``; ``mobileai``: grippers at 6 and 13; ``widowxai``: the
    gripper at 6)."""
    out = np.array(action16, dtype=np.float64, copy=True)
    fingers = _FINGERS
    if recorded == "mobileai":
        fingers = [MOBILEAI_LAYOUT.gripper_index(side) for side in SIDES]
    elif recorded == "widowxai":
        fingers = [WIDOWXAI_LAYOUT.size - 1]  # one arm's 7: the gripper last
    out[..., fingers] = np.minimum(out[..., fingers], GRIPPER_MAX)
    return out


def _values(
    episode: Episode,
    layout: str,
    frames: FrameMap,
    extras: tuple[str, ...] = (),
    base_action: str | None = None,
) -> dict[str, np.ndarray]:
    action = frames.actions(
        fmt.layout_values(layout, controller_actions(episode.action, recorded_layout(episode)))
    )
    if layout == MOBILEAI and base_action != "commanded":  # the measured base velocity
        base = MOBILEAI_LAYOUT.base
        action[:, base] = frames.observations(np.asarray(episode.qpos)[:, base])
    out = {
        ACTION_KEY: action,
        STATE_KEY: frames.observations(state_source(episode, layout, extras)),
        VELOCITY_KEY: frames.observations(fmt.layout_values(layout, episode.qvel)),
    }
    if episode.env_state is not None:
        poses = frames.poses(episode.env_state)
        goal = episode_goal(episode)
        if goal is not None:  # a goal-conditioned task: the goal after the poses
            poses = np.hstack([poses, np.broadcast_to(goal, (len(poses), 3))])
        out[ENV_STATE_KEY] = poses
    out = {key: values.astype(np.float32) for key, values in out.items()}
    if episode.reward is not None:
        out["next.reward"] = episode.reward[frames.reward_index].astype(np.float32)
    out["image_index"] = frames.image_index
    return out


def frame_columns(
    ep: Episode, plan: ExportPlan, i: int, first_index: int
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Per-frame values of one episode for every non-video feature.

    Args:
        ep: the episode.
        plan: the checked export (:func:`~.lerobot_plan.plan_export`).
        i: the episode's index in the dataset.
        first_index: the dataset-wide ``index`` of the episode's first frame.

    Returns:
        Feature key -> ``(K, ...)`` column, and the source step of each frame's images
        (int ``(K,)``).
    """
    frames = frame_map(ep.num_steps, plan.source_fps, plan.fps)
    cols = _values(ep, plan.layout, frames, plan.state_extras, plan.base_action)
    image_index = cols.pop("image_index")
    if not plan.sim_features:
        cols = {key: values for key, values in cols.items() if key not in fmt.SIM_FEATURES}
    elif (judge := plan.goal_judges[i] if plan.goal_judges else None) is not None:
        goal = episode_goal(ep)
        cols["next.success"] = judge.success(cols[ENV_STATE_KEY], goal)
    elif plan.with_reward:
        cols["next.success"] = ep.reward[frames.reward_index] >= plan.max_reward[i]
    n = frames.length
    cols["timestamp"] = (np.arange(n) / plan.fps).astype(np.float32)
    cols["frame_index"] = np.arange(n, dtype=np.int64)
    cols["episode_index"] = np.full(n, i, dtype=np.int64)
    cols["index"] = np.arange(first_index, first_index + n, dtype=np.int64)
    cols["task_index"] = np.full(n, plan.task_index[i], dtype=np.int64)
    return cols, image_index
