"""HDF5 episodes -> a LeRobot v3.0 dataset (layout in :mod:`.lerobot_format`).

By default the dataset is what ``lerobot-record`` writes with Trossen's LeRobot plugin robot
of the layout: its ``robot_type``, 30 frames per second, the features ``action``,
``observation.state`` and ``observation.images.<camera>`` with the plugin's names and order
(joints in rad, gripper carriages in m); ``sim_features`` adds the simulation's own. Frames
are resampled from the recording rate by the rule of :mod:`.lerobot_plan`. The export is
atomic: every episode is validated first, the dataset is built in ``.<output name>.tmp`` and
renamed onto ``output`` only when complete; an error or a signal leaves ``output`` as it was.

Docs: docs/datasets.md (The LeRobot export), docs/cli/export.md; design notes:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.errors import UserError, describe_os_error, interrupt_note, os_error_hint
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.export.lerobot_frames import controller_actions, frame_values
from trossen_arm_mujoco.export.lerobot_output import (
    build_folder,
    check_output,
    error_where,
    kept_note,
    prepare_output,
    publish,
    recover_old,
)
from trossen_arm_mujoco.export.lerobot_plan import plan_export
from trossen_arm_mujoco.export.lerobot_state import state_extras
from trossen_arm_mujoco.export.lerobot_video import VideoSettings
from trossen_arm_mujoco.export.lerobot_writer import write_dataset
from trossen_arm_mujoco.fileio import FolderBusyError, deferred_signals, temp_path

__all__ = ["REPO_ID_RE", "ExportSummary", "controller_actions", "export_lerobot", "frame_values"]

#: A dataset name: ``<owner>/<name>`` as on the Hugging Face Hub.
REPO_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*/[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class ExportSummary:
    """What an export wrote."""

    output: Path
    episodes: int
    frames: int
    cameras: list[str]
    fps: int
    tasks: list[str]
    seconds: float
    source_fps: int
    layout: str
    state_extras: tuple[str, ...] = ()  # "vel", "eff", "ext_eff": per-joint values in the state
    sim_features: bool = False  # observation.velocity, environment_state, next.reward/success
    base_action: str | None = None  # the Mobile AI's: "measured" or "commanded"


def export_lerobot(
    data_dir: str | os.PathLike[str],
    output: str | os.PathLike[str],
    repo_id: str,
    *,
    task: str | None = None,
    video: VideoSettings | None = None,
    overwrite: bool = False,
    progress: bool = True,
    layout: str | None = None,
    fps: int | None = None,
    include_velocity: bool = False,
    include_effort: bool = False,
    include_external_effort: bool = False,
    sim_features: bool = False,
    base_action: str | None = None,
) -> ExportSummary:
    """Write the episodes of ``data_dir`` as a LeRobot v3.0 dataset in ``output``.

    Args:
        data_dir: folder of ``episode_<k>.hdf5`` files (float32 or float64 arrays,
            compressed or raw images); episodes become 0, 1, ... in ``k`` order.
        output: dataset folder; must be missing or empty unless ``overwrite``, which
            replaces a LeRobot dataset there once the new one is complete.
        repo_id: dataset name, ``<owner>/<name>`` (what ``LeRobotDataset(repo_id, root=output)``
            is given; nothing is uploaded).
        task: task description for every episode (default: the registry's description of
            each episode's ``task_name``; required for vendor recordings).
        video: camera encoding (default: AV1 yuv420p CRF 30, as LeRobot).
        overwrite: replace an existing dataset in ``output``.
        progress: show a progress bar over episodes on stderr.
        layout: joint layout of state, velocity and action: ``"kit14"`` (the real kit's 14
            values), ``"vendor16"`` (the HDF5 files' 16), ``"mobileai"`` (the Mobile AI's
            14 arm values then ``x.vel``, ``theta.vel``) or ``"widowxai"`` (one arm's 7);
            None: the one that fits the recordings (``lerobot_plan.resolve_layout``).
        fps: frames per second to write, a whole number up to the recording rate (None: 30,
            the plugin's loop rate, or the recording rate if lower); below the recording
            rate the episodes are resampled (module docstring).
        include_velocity, include_effort, include_external_effort: add each joint's
            ``.vel`` (rad/s, m/s) / ``.eff`` / ``.ext_eff`` (Nm, N) values to
            ``observation.state`` (the plugin's layouts; module docstring).
        sim_features: add the simulation's features (module docstring).
        base_action: the Mobile AI's base action, ``"measured"`` (None: the default) or
            ``"commanded"``; a UserError for other layouts unless ``"measured"``.

    Raises:
        UserError: missing folder, no episodes, a corrupt or inconsistent episode, a
            non-empty output, an unknown layout, a bad ``fps``, a missing optional
            dependency (one line each).
    """
    start = time.perf_counter()
    _check_repo_id(repo_id)
    data_dir, output = Path(data_dir).expanduser(), check_output(output, overwrite)
    require("pyarrow")
    found = list_episodes(data_dir)
    if not found:
        raise UserError(f"no episode_<k>.hdf5 files in {data_dir}; record episodes first")
    extras = state_extras(include_velocity, include_effort, include_external_effort)
    plan = plan_export(
        [load_episode(path) for _, path in found],
        task,
        layout,
        fps,
        extras,
        sim_features=sim_features,
        base_action=base_action,
    )
    video = video or VideoSettings()
    if plan.cameras:
        video.check_available()
    state = {"existing": False, "published": False}
    try:
        with interrupt_note(lambda: kept_note(output, **state)):
            output.parent.mkdir(parents=True, exist_ok=True)
            with build_folder(output) as tmp:
                recover_old(output)
                prepare_output(output, overwrite)
                state["existing"] = (output / fmt.INFO_PATH).is_file()
                frames = write_dataset(tmp, plan, video, progress)
                with deferred_signals():
                    publish(tmp, output)
                    state["published"] = True
    except FolderBusyError:
        raise UserError(
            f"another export is writing {output} (its build folder {temp_path(output)} is "
            "locked); wait for it to finish or choose another --output"
        ) from None
    except OSError as exc:
        raise UserError(
            f"export to {output} failed: {describe_os_error(exc)}{error_where(exc)}; the partial "
            f"dataset was removed and {output} left as it was; {os_error_hint(exc, '--output')}"
        ) from None
    return ExportSummary(
        output=output,
        episodes=len(plan.episodes),
        frames=frames,
        cameras=plan.cameras,
        fps=plan.fps,
        tasks=plan.tasks,
        seconds=time.perf_counter() - start,
        source_fps=plan.source_fps,
        layout=plan.layout,
        state_extras=plan.state_extras,
        sim_features=plan.sim_features,
        base_action=plan.base_action,
    )


def _check_repo_id(repo_id: str) -> None:
    if not REPO_ID_RE.match(repo_id):
        raise UserError(
            f"--repo_id must look like <owner>/<name> (letters, digits, - _ .), got '{repo_id}'"
        )
