"""HDF5 episodes -> a LeRobot v3.0 dataset (layout in :mod:`.lerobot_format`).

Per frame ``t`` of an episode:

- ``observation.state``: qpos (16, float32; rad, fingers m), ``observation.velocity``: qvel,
  ``action``: the joint targets; names are the kit layout's joint names.
- ``observation.images.<camera>``: the camera image, as a frame of the camera's mp4.
- ``next.reward``: the task reward after action ``t``; ``next.success``: whether the task
  judges it a success then (reward reaches the task's maximum). Left out for files
  without rewards (vendor recordings).
- ``task``: the task's description from the registry (or ``task=``).

Every episode file is validated before anything is written; the dataset is built in a
hidden sibling folder and renamed onto ``output`` only when complete.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.data.reader import Episode, list_episodes, load_episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export import lerobot_stats as st
from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.export.lerobot_plan import ExportPlan, plan_export
from trossen_arm_mujoco.export.lerobot_video import CameraVideo, VideoSettings

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


def _prepare_output(output: Path, overwrite: bool) -> None:
    if output.exists() and not output.is_dir():
        raise UserError(f"--output {output} is a file; give a folder")
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


def export_lerobot(
    data_dir: str | os.PathLike[str],
    output: str | os.PathLike[str],
    repo_id: str,
    *,
    task: str | None = None,
    video: VideoSettings | None = None,
    overwrite: bool = False,
    progress: bool = True,
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

    Raises:
        UserError: missing folder, no episodes, a corrupt or inconsistent episode, a
            non-empty output, a missing optional dependency (one line each).
    """
    start = time.perf_counter()
    _check_repo_id(repo_id)
    data_dir, output = Path(data_dir).expanduser(), Path(output).expanduser().resolve()
    require("pyarrow")
    found = list_episodes(data_dir)
    if not found:
        raise UserError(f"no episode_<k>.hdf5 files in {data_dir}; record episodes first")
    plan = plan_export([load_episode(path) for _, path in found], task)
    video = video or VideoSettings()
    if plan.cameras:
        video.check_available()
    _prepare_output(output, overwrite)

    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(f".{output.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        frames = _write_dataset(tmp, plan, video, progress)
        _publish(tmp, output)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return ExportSummary(
        output=output,
        episodes=len(plan.episodes),
        frames=frames,
        cameras=plan.cameras,
        fps=plan.fps,
        tasks=plan.tasks,
        seconds=time.perf_counter() - start,
    )


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


def _frame_columns(
    ep: Episode, plan: ExportPlan, i: int, first_index: int
) -> dict[str, np.ndarray]:
    """Per-frame values of episode ``i`` for every non-video feature."""
    T = ep.num_steps
    cols = {key: getattr(ep, attr).astype(np.float32) for key, attr in fmt.VECTOR_FEATURES.items()}
    if plan.with_reward:
        cols["next.reward"] = ep.reward.astype(np.float32)
        cols["next.success"] = ep.reward >= plan.max_reward[i]
    cols["timestamp"] = (np.arange(T) / plan.fps).astype(np.float32)
    cols["frame_index"] = np.arange(T, dtype=np.int64)
    cols["episode_index"] = np.full(T, i, dtype=np.int64)
    cols["index"] = np.arange(first_index, first_index + T, dtype=np.int64)
    cols["task_index"] = np.full(T, plan.task_index[i], dtype=np.int64)
    return cols


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


def _encode_camera(ep: Episode, cam: str, writer: CameraVideo) -> list[np.ndarray]:
    """Encode one camera of ``ep``; returns the frames sampled for statistics."""
    sampled = set(st.image_sample_indices(ep.num_steps).tolist())
    samples = []
    with ep.open_frames() as frames:
        for t in range(ep.num_steps):
            image = frames.read(cam, t)
            writer.write(image[None])
            if t in sampled:
                samples.append(st.downsample(image).copy())
    return samples


def _write_dataset(root: Path, plan: ExportPlan, video: VideoSettings, progress: bool) -> int:
    """Write the whole dataset into ``root``; returns the number of frames."""
    infos = {cam: video.info(h, w, plan.fps) for cam, (h, w, _) in plan.image_shapes.items()}
    features = fmt.build_features(plan.image_shapes, infos, plan.with_reward)
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
            columns = _frame_columns(ep, plan, i, total)
            where = data.write(_table(columns, schema))
            row: dict[str, Any] = {
                "episode_index": i,
                "tasks": [plan.tasks[plan.task_index[i]]],
                "length": ep.num_steps,
                "data/chunk_index": where.chunk,
                "data/file_index": where.file,
                "dataset_from_index": total,
                "dataset_to_index": total + ep.num_steps,
            }
            ep_stats = {key: st.array_stats(values) for key, values in columns.items()}
            for cam, writer in videos.items():
                key = fmt.video_key(cam)
                index, start = writer.begin_episode()
                ep_stats[key] = st.image_stats(_encode_camera(ep, cam, writer))
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
            total += ep.num_steps
        bar.close()
        data.close()
        for writer in videos.values():
            writer.close()
    except BaseException:
        data.close()
        for writer in videos.values():
            writer.abort()
        raise
    fmt.write_episodes(root / fmt.FileIndex().path(fmt.EPISODES_PATH), rows)
    fmt.write_tasks(root / fmt.TASKS_PATH, plan.tasks)
    fmt.write_json(
        root / fmt.STATS_PATH, {key: st.to_lists(st.aggregate(s)) for key, s in stats.items()}
    )
    info = fmt.build_info(features, plan.fps, len(plan.episodes), total, len(plan.tasks))
    fmt.write_json(root / fmt.INFO_PATH, info)
    return total
