"""HDF5 episodes -> a LeRobot v3.0 dataset (layout in :mod:`.lerobot_format`).

Per written frame ``k``:

- ``observation.state``: qpos, ``observation.velocity``: qvel, ``action``: the joint
  targets, float32 in the chosen layout: ``kit14`` (default), the real kit's 14 values as
  Trossen's LeRobot plugin for the kit (``bi_widowxai_follower_robot``) names them,
  ``left_joint_0.pos`` .. ``left_joint_5.pos``, ``left_left_carriage_joint.pos``, then
  ``right_...`` (rad; the carriage, the gripper, in m; the coupled second finger dropped);
  or ``vendor16``, the HDF5 files' 16 values and names. The action's grippers are as the
  arm controller executes them, at most 0.04 m (:func:`controller_actions`). With
  ``include_velocity`` / ``include_effort`` the state also holds each joint's ``.vel`` /
  ``.eff`` values after each arm's positions, as Trossen's plugin names them
  (:mod:`.lerobot_state`; efforts derived with MuJoCo's actuator model, :mod:`.joint_efforts`).
- ``observation.environment_state``: the episode's env_state, 7 values per object (xyz m,
  quat wxyz) named ``<object>_x`` .. ``<object>_qz``; left out for files without it
  (vendor recordings).
- ``observation.images.<camera>``: the camera image, as a frame of the camera's mp4.
- ``next.reward``: the task reward after the frame's action; ``next.success``: whether the
  task judges it a success then (reward reaches the task's maximum). Left out for files
  without rewards (vendor recordings).
- ``task``: the task's description from the registry (or ``task=``).

At the recording rate (default) frame ``k`` is source step ``k``. At a lower ``fps`` N
(the real kit runs at 30) frame ``k`` is at ``t_k = k / N``: state, velocity and
environment_state are the source linearly interpolated at ``t_k`` (quaternions renormalised);
images are the source frame nearest ``t_k``; the action is the source action trajectory
interpolated at ``t_k + 1/N - dt`` (action ``j`` being the target for the end of step ``j``,
holding it for ``1/N`` s reaches where the source was at ``t_{k+1}``); reward and success are
those of the source step whose period contains ``t_{k+1}``. An episode of ``T`` steps gives
``floor(T dt N)`` frames: later ones would need an action past the episode's end. The exact
rule is in :mod:`.lerobot_plan`.

An output it cannot write (a file or a broken link in the way, a non-empty folder, a
read-only or unwritable parent) stops the export with one line before any episode is read.
Every episode file is validated before anything is written; the dataset is built in a
hidden sibling folder, ``.<output name>.tmp``, and renamed onto ``output`` only when
complete. An error, Ctrl-C or SIGTERM removes the build folder and leaves ``output`` as it
was; the build folder is locked while in use, so the next export removes one that a killed
run (SIGKILL) left behind, and refuses to start while another export builds the same
dataset. A file system that refuses the writes (full, read-only) is a one-line UserError.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.data.reader import Episode, list_episodes, load_episode
from trossen_arm_mujoco.errors import (
    UserError,
    describe_os_error,
    interrupt_note,
    os_error_hint,
)
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export import lerobot_stats as st
from trossen_arm_mujoco.export.dataset_settings import INFO_KEY
from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.export.lerobot_plan import (
    ExportPlan,
    FrameMap,
    episode_frames,
    frame_map,
    plan_export,
    recorded_layout,
    resolve_layout,
)
from trossen_arm_mujoco.export.lerobot_state import state_extras, state_names, state_source
from trossen_arm_mujoco.export.lerobot_video import CameraVideo, VideoSettings
from trossen_arm_mujoco.fileio import (
    FolderBusyError,
    check_folder_path,
    check_writable_dir,
    deferred_signals,
    folder_lock,
    temp_path,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT, SIDES
from trossen_arm_mujoco.robot.lerobot_keys import ACTION_KEY, ENV_STATE_KEY, STATE_KEY, VELOCITY_KEY

__all__ = ["REPO_ID_RE", "ExportSummary", "export_lerobot", "frame_values"]

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
    state_extras: tuple[str, ...] = ()  # "vel", "eff": per-joint values in the state


def _prepare_output(output: Path, overwrite: bool) -> None:
    if output.exists() and not output.is_dir():
        raise UserError(f"--output {output} is a file; give a folder")
    if os.path.ismount(output):  # the dataset is built next to it and renamed onto it
        raise UserError(f"--output {output} is a mount point; give a folder inside it")
    if output.is_dir() and any(output.iterdir()):
        if not overwrite:
            raise UserError(
                f"output folder {output} is not empty; choose another --output or pass "
                "--overwrite to replace the dataset in it"
            )
        if not (output / fmt.INFO_PATH).is_file():
            raise UserError(
                f"output folder {output} is not empty and holds no LeRobot dataset "
                f"(no {fmt.INFO_PATH}); refusing to delete it, choose another --output"
            )


def _check_output(output: str | os.PathLike[str], overwrite: bool) -> Path:
    """Before any episode is read: ``output`` can become the dataset folder (not a file, a
    symlink loop or a link to a missing path; missing, empty or, with ``overwrite``, a
    dataset), and its parent, where the dataset is built and renamed onto ``output``, is a
    folder this process can write in (created if missing, as the export will). Returns
    ``output`` resolved."""
    check_folder_path(output, "--output")  # first: resolving a symlink loop raises
    output = Path(output).expanduser().resolve()
    _prepare_output(output, overwrite)
    check_writable_dir(output.parent, "--output")
    return output


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
            values), ``"vendor16"`` (the HDF5 files' 16) or ``"mobileai"`` (the Mobile AI's
            14 arm values then ``x.vel``, ``theta.vel``); None: ``mobileai`` for the Mobile
            AI's recordings, else ``kit14`` (``lerobot_plan.resolve_layout``).
        fps: frames per second to write, a whole number up to the recording rate (None: the
            recording rate); below it the episodes are resampled (module docstring).
        include_velocity, include_effort: add each joint's ``.vel`` (rad/s, m/s) / ``.eff``
            (Nm, N) values to ``observation.state`` (kit14 only; module docstring).

    Raises:
        UserError: missing folder, no episodes, a corrupt or inconsistent episode, a
            non-empty output, an unknown layout, a bad ``fps``, a missing optional
            dependency (one line each).
    """
    start = time.perf_counter()
    _check_repo_id(repo_id)
    data_dir, output = Path(data_dir).expanduser(), _check_output(output, overwrite)
    require("pyarrow")
    found = list_episodes(data_dir)
    if not found:
        raise UserError(f"no episode_<k>.hdf5 files in {data_dir}; record episodes first")
    extras = state_extras(include_velocity, include_effort)
    plan = plan_export([load_episode(path) for _, path in found], task, layout, fps, extras)
    video = video or VideoSettings()
    if plan.cameras:
        video.check_available()
    state = {"existing": False, "published": False}
    try:
        with interrupt_note(lambda: _kept(output, **state)):
            output.parent.mkdir(parents=True, exist_ok=True)
            with _build_folder(output) as tmp:
                _recover_old(output)
                _prepare_output(output, overwrite)
                state["existing"] = (output / fmt.INFO_PATH).is_file()
                frames = _write_dataset(tmp, plan, video, progress)
                with deferred_signals():
                    _publish(tmp, output)
                    state["published"] = True
    except FolderBusyError:
        raise UserError(
            f"another export is writing {output} (its build folder {temp_path(output)} is "
            "locked); wait for it to finish or choose another --output"
        ) from None
    except OSError as exc:
        raise UserError(
            f"export to {output} failed: {describe_os_error(exc)}{_where(exc)}; the partial "
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
    )


@contextmanager
def _build_folder(output: Path) -> Iterator[Path]:
    """The hidden folder the dataset is built in, empty and locked for this export, and
    removed on the way out (error, Ctrl-C, SIGTERM). One a killed run left is reused after
    emptying it; one another export holds raises FolderBusyError."""
    tmp = temp_path(output)
    if tmp.is_symlink() or (tmp.exists() and not tmp.is_dir()):
        tmp.unlink()
    try:
        tmp.mkdir()
    except FileExistsError:  # a killed run's, or another export's: the lock tells
        pass
    with folder_lock(tmp):
        ours = _identity(tmp)
        try:
            for entry in list(tmp.iterdir()):  # a killed run's leftovers
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
            yield tmp
        finally:
            with deferred_signals():  # a second signal must not stop the cleanup
                if _identity(tmp) == ours:  # not yet published, nor another export's since
                    shutil.rmtree(tmp, ignore_errors=True)


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _recover_old(output: Path) -> None:
    """Deal with the ``.<name>.old`` folder of a run killed while replacing a dataset: put
    it back when ``output`` is missing (the old dataset is never lost), else remove it.
    Called holding the build folder's lock."""
    old = output.with_name(f".{output.name}.old")
    if not old.is_dir():
        return
    with deferred_signals():
        if output.exists():
            shutil.rmtree(old)
        else:
            os.replace(old, output)


def _kept(output: Path, existing: bool, published: bool) -> str:
    """What an interrupted export kept, for the one line of ``run_cli``."""
    if published:
        return f"the export had finished: the dataset is complete in {output}"
    if existing:
        return f"the partial dataset was removed; the dataset already in {output} is unchanged"
    return f"the partial dataset was removed; nothing was written to {output}"


def _where(exc: OSError) -> str:
    name = getattr(exc, "filename", None)
    return f" ({name})" if name else ""


def _publish(tmp: Path, output: Path) -> None:
    """Move the finished dataset ``tmp`` onto ``output`` (empty, or a dataset to replace:
    it is moved aside first and put back if the move fails)."""
    if not output.exists():
        os.replace(tmp, output)
        return
    old = output.with_name(f".{output.name}.old")
    shutil.rmtree(old, ignore_errors=True)
    os.replace(output, old)
    try:
        os.replace(tmp, output)
    except BaseException:
        os.replace(old, output)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _check_repo_id(repo_id: str) -> None:
    if not REPO_ID_RE.match(repo_id):
        raise UserError(
            f"--repo_id must look like <owner>/<name> (letters, digits, - _ .), got '{repo_id}'"
        )


class _DataFiles:
    """The rolling frame parquet files: one row group per episode."""

    def __init__(self, root: Path, schema: Any) -> None:
        self._pq = require("pyarrow.parquet", "pyarrow")
        self.root, self.schema = root, schema
        self.max_bytes = fmt.DATA_FILES_SIZE_MB * 1024 * 1024
        self.index = fmt.FileIndex()
        self._path: Path | None = None
        self._writer: Any = None

    def write(self, table: Any) -> fmt.FileIndex:
        """Append one episode; returns the file it went to."""
        if self._writer is not None and self._path.stat().st_size >= self.max_bytes:
            self.close()
            self.index = self.index.next(fmt.CHUNKS_SIZE)
        if self._writer is None:
            self._path = self.root / self.index.path(fmt.DATA_PATH)
            self._path.parent.mkdir(parents=True, exist_ok=True)
            self._writer = self._pq.ParquetWriter(self._path, self.schema, compression="snappy")
        self._writer.write_table(table)
        return self.index

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None


def frame_values(
    episode: Episode,
    layout: str | None = None,
    fps: int | None = None,
    extras: tuple[str, ...] = (),
) -> dict[str, np.ndarray]:
    """What an export writes for ``episode`` per frame, before any encoding.

    Returns:
        ``observation.state``, ``observation.velocity``, ``action``: float32 ``(K, D)`` in
        ``layout``; ``observation.environment_state``: float32 ``(K, 7k)`` (episodes with
        env_state); ``next.reward``: float32 ``(K,)`` (episodes with rewards);
        ``image_index``: int64 ``(K,)``, the source step whose images frame ``k`` shows.
        ``K`` frames at ``fps`` (None: the recording rate); see the module docstring.
        ``extras`` (``"vel"``, ``"eff"``) widen the state (``lerobot_state.state_names``).
        ``layout`` None: the one that fits the episode (``lerobot_plan.resolve_layout``).

    Raises:
        UserError: an unknown layout or one that does not fit the episode, a bad ``fps``,
            an episode too short for ``fps``.
    """
    layout = resolve_layout([episode], layout)
    return _values(episode, layout, episode_frames(episode, fps), extras)


#: The finger values of the HDF5 files' 16 (left 6, 7; right 14, 15).
_FINGERS = [6, 7, 14, 15]


def controller_actions(action16: np.ndarray, recorded: str = "vendor16") -> np.ndarray:
    """The recorded actions ``(T, 16)`` as the arm controller executes them: each gripper
    at most ``GRIPPER_MAX`` (0.04 m per finger; the controller clips the recorder's fully
    open 0.044 m to it). A policy learns the opening the arm reaches, and its own small
    errors around it stay inside the controller's 0.044 + 0.001 m position check (around
    0.044 they do not: about half its open-gripper actions would fault). ``recorded``: the
    layout of the rows (``vendor16``, or ``mobileai``: grippers at 6 and 13)."""
    out = np.array(action16, dtype=np.float64, copy=True)
    fingers = _FINGERS
    if recorded == "mobileai":
        fingers = [MOBILEAI_LAYOUT.gripper_index(side) for side in SIDES]
    out[..., fingers] = np.minimum(out[..., fingers], GRIPPER_MAX)
    return out


def _values(
    episode: Episode, layout: str, frames: FrameMap, extras: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    state = state_source(episode, layout, extras) if extras else None
    out = {
        STATE_KEY: frames.observations(
            fmt.layout_values(layout, episode.qpos) if state is None else state
        ),
        VELOCITY_KEY: frames.observations(fmt.layout_values(layout, episode.qvel)),
        ACTION_KEY: frames.actions(
            fmt.layout_values(layout, controller_actions(episode.action, recorded_layout(episode)))
        ),
    }
    if episode.env_state is not None:
        out[ENV_STATE_KEY] = frames.poses(episode.env_state)
    out = {key: values.astype(np.float32) for key, values in out.items()}
    if episode.reward is not None:
        out["next.reward"] = episode.reward[frames.reward_index].astype(np.float32)
    out["image_index"] = frames.image_index
    return out


def _frame_columns(
    ep: Episode, plan: ExportPlan, i: int, first_index: int
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Per-frame values of episode ``i`` for every non-video feature, and the source step
    of each frame's images."""
    frames = frame_map(ep.num_steps, plan.source_fps, plan.fps)
    cols = _values(ep, plan.layout, frames, plan.state_extras)
    image_index = cols.pop("image_index")
    if plan.with_reward:
        cols["next.success"] = ep.reward[frames.reward_index] >= plan.max_reward[i]
    n = frames.length
    cols["timestamp"] = (np.arange(n) / plan.fps).astype(np.float32)
    cols["frame_index"] = np.arange(n, dtype=np.int64)
    cols["episode_index"] = np.full(n, i, dtype=np.int64)
    cols["index"] = np.arange(first_index, first_index + n, dtype=np.int64)
    cols["task_index"] = np.full(n, plan.task_index[i], dtype=np.int64)
    return cols, image_index


def _table(columns: dict[str, np.ndarray], schema: Any) -> Any:
    pa = require("pyarrow")
    arrays = []
    for field in schema:
        values = columns[field.name]
        if values.ndim == 2:
            flat = pa.array(values.reshape(-1), type=field.type.value_type)
            arrays.append(pa.FixedSizeListArray.from_arrays(flat, values.shape[1]))
        else:
            arrays.append(pa.array(values, type=field.type))
    return pa.Table.from_arrays(arrays, schema=schema)


def _encode_camera(
    ep: Episode, cam: str, writer: CameraVideo, image_index: np.ndarray
) -> list[np.ndarray]:
    """Encode one camera of ``ep``, written frame ``k`` showing source step
    ``image_index[k]``; returns the frames sampled for statistics."""
    sampled = set(st.image_sample_indices(len(image_index)).tolist())
    samples = []
    with ep.open_frames() as frames:
        for k, t in enumerate(image_index.tolist()):
            image = frames.read(cam, t)
            writer.write(image[None])
            if k in sampled:
                samples.append(st.downsample(image).copy())
    return samples


def _write_dataset(root: Path, plan: ExportPlan, video: VideoSettings, progress: bool) -> int:
    """Write the whole dataset into ``root``; returns the number of frames."""
    infos = {cam: video.info(h, w, plan.fps) for cam, (h, w, _) in plan.image_shapes.items()}
    names = state_names(plan.layout, plan.state_extras) if plan.state_extras else None
    features = fmt.build_features(
        plan.image_shapes, infos, plan.with_reward, plan.layout, plan.env_names, names
    )
    schema = fmt.data_schema(features)
    data = _DataFiles(root, schema)
    videos = {
        cam: CameraVideo(
            root, fmt.video_key(cam), fmt.VIDEO_PATH, video, plan.fps, h, w,
            fmt.VIDEO_FILES_SIZE_MB, fmt.CHUNKS_SIZE,
        )
        for cam, (h, w, _) in plan.image_shapes.items()
    }  # fmt: skip
    rows: list[dict[str, Any]] = []
    stats: dict[str, list[st.Stats]] = {key: [] for key in features}
    total = 0
    try:
        bar = tqdm(
            plan.episodes, desc="export", unit="episode", file=sys.stderr, disable=not progress
        )
        for i, ep in enumerate(bar):
            columns, image_index = _frame_columns(ep, plan, i, total)
            length = len(image_index)
            where = data.write(_table(columns, schema))
            row: dict[str, Any] = {
                "episode_index": i,
                "tasks": [plan.tasks[plan.task_index[i]]],
                "length": length,
                "data/chunk_index": where.chunk,
                "data/file_index": where.file,
                "dataset_from_index": total,
                "dataset_to_index": total + length,
            }
            ep_stats = {key: st.array_stats(values) for key, values in columns.items()}
            for cam, writer in videos.items():
                key = fmt.video_key(cam)
                index, start = writer.begin_episode()
                ep_stats[key] = st.image_stats(_encode_camera(ep, cam, writer, image_index))
                row[f"videos/{key}/chunk_index"] = index.chunk
                row[f"videos/{key}/file_index"] = index.file
                row[f"videos/{key}/from_timestamp"] = start
                row[f"videos/{key}/to_timestamp"] = writer.end_episode()
            for key in features:
                stats[key].append(ep_stats[key])
                for name, value in st.to_lists(ep_stats[key]).items():
                    row[f"stats/{key}/{name}"] = value
            row["meta/episodes/chunk_index"] = 0
            row["meta/episodes/file_index"] = 0
            rows.append(row)
            total += length
        bar.close()
        data.close()
        for writer in videos.values():
            writer.close()
    except BaseException:
        for close in (data.close, *(writer.abort for writer in videos.values())):
            try:
                close()
            except Exception:  # the folder is deleted anyway; report the first error
                pass
        raise
    fmt.write_episodes(root / fmt.FileIndex().path(fmt.EPISODES_PATH), rows)
    fmt.write_tasks(root / fmt.TASKS_PATH, plan.tasks)
    fmt.write_json(
        root / fmt.STATS_PATH, {key: st.to_lists(st.aggregate(s)) for key, s in stats.items()}
    )
    info = fmt.build_info(
        features, plan.fps, len(plan.episodes), total, len(plan.tasks), plan.layout
    )
    info[INFO_KEY] = plan.settings().to_json()  # what a checkpoint trained on it carries
    fmt.write_json(root / fmt.INFO_PATH, info)
    return total
