"""Which episodes a LeRobot export holds, checked before anything is written.

All episodes must share the frame rate (a whole number of frames per second), the cameras
and their image sizes, and either all have rewards or none (vendor recordings). Each gets a
task description (the registry's, or the one given) and, when it has rewards, the task's
maximum reward, which marks success.
"""

from __future__ import annotations

from dataclasses import dataclass

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry


@dataclass
class ExportPlan:
    """Checked facts about the episodes to export.

    Attributes:
        episodes: in export order (episode_index 0, 1, ...).
        fps: frames per second, ``1 / dt``.
        cameras: camera names in recording order; image_shapes: ``{camera: (H, W, 3)}``.
        with_reward: the episodes have rewards (``next.reward`` / ``next.success``).
        tasks: distinct task descriptions, in ``task_index`` order.
        task_index: per episode, its task's index.
        max_reward: per episode, the reward that means success (None without rewards).
    """

    episodes: list[Episode]
    fps: int
    cameras: list[str]
    image_shapes: dict[str, tuple[int, int, int]]
    with_reward: bool
    tasks: list[str]  # distinct descriptions, task_index order
    task_index: list[int]  # per episode
    max_reward: list[float | None]  # per episode


def _fps(episode: Episode) -> int:
    rate = 1.0 / episode.dt
    fps = round(rate)
    if fps < 1 or abs(rate - fps) > 1e-6 * rate:
        raise UserError(
            f"{episode.path.name}: step period dt={episode.dt:g} s gives {rate:g} frames/s; "
            "LeRobot datasets need a whole number of frames per second"
        )
    return fps


def plan_export(episodes: list[Episode], task: str | None) -> ExportPlan:
    """Check ``episodes`` (at least one) for export; ``task`` overrides every description.

    Raises:
        UserError: mixed rates, cameras or rewards; no task to describe an episode with.
    """
    first = episodes[0]
    fps = _fps(first)
    tasks: list[str] = []
    task_index: list[int] = []
    max_reward: list[float | None] = []
    for ep in episodes:
        if _fps(ep) != fps:
            raise UserError(
                f"{ep.path.name} runs at {_fps(ep)} frames/s but {first.path.name} at {fps}; "
                "export episodes of one rate together"
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
        max_reward.append(None if entry is None else float(entry.task_class().max_reward))
    return ExportPlan(
        episodes=episodes,
        fps=fps,
        cameras=list(first.camera_names),
        image_shapes={cam: first.image_shapes[cam] for cam in first.camera_names},
        with_reward=first.reward is not None,
        tasks=tasks,
        task_index=task_index,
        max_reward=max_reward,
    )


def _describe_cams(ep: Episode) -> str:
    cams = [f"{cam} {h}x{w}" for cam, (h, w, _) in ep.image_shapes.items()]
    return "[" + ", ".join(cams) + "]" if cams else "none"
