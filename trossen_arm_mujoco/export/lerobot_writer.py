"""Write a planned LeRobot v3.0 dataset into a folder: the frame parquet files, one mp4
stream per camera, and ``meta/`` (episodes, tasks, stats, info with the dataset's settings).

The files and their layout are ``lerobot_format``'s; the values of each frame
``lerobot_frames``'; the statistics ``lerobot_stats``'; the videos ``lerobot_video``'s.

Docs: docs/datasets.md (The LeRobot export).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export import lerobot_stats as st
from trossen_arm_mujoco.export.dataset_settings import INFO_KEY
from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.export.lerobot_frames import frame_columns
from trossen_arm_mujoco.export.lerobot_plan import ExportPlan
from trossen_arm_mujoco.export.lerobot_state import state_names
from trossen_arm_mujoco.export.lerobot_video import CameraVideo, VideoSettings

__all__ = ["DataFiles", "write_dataset"]


class DataFiles:
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
        """Finish the file being written (nothing when none is open)."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None


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


def write_dataset(root: Path, plan: ExportPlan, video: VideoSettings, progress: bool) -> int:
    """Write the whole dataset into ``root``.

    Args:
        root: the (empty) build folder.
        plan: the checked export (:func:`~.lerobot_plan.plan_export`).
        video: the video encoding.
        progress: show a progress bar over the episodes.

    Returns:
        The number of frames written.
    """
    infos = {cam: video.info(h, w, plan.fps) for cam, (h, w, _) in plan.image_shapes.items()}
    names = state_names(plan.layout, plan.state_extras) if plan.state_extras else None
    features = fmt.build_features(
        plan.image_shapes,
        infos,
        plan.with_reward,
        plan.layout,
        plan.env_names,
        names,
        sim_features=plan.sim_features,
    )
    schema = fmt.data_schema(features)
    data = DataFiles(root, schema)
    videos = {
        cam: CameraVideo(
            root,
            fmt.video_key(cam),
            fmt.VIDEO_PATH,
            video,
            plan.fps,
            h,
            w,
            fmt.VIDEO_FILES_SIZE_MB,
            fmt.CHUNKS_SIZE,
        )
        for cam, (h, w, _) in plan.image_shapes.items()
    }
    rows: list[dict[str, Any]] = []
    stats: dict[str, list[st.Stats]] = {key: [] for key in features}
    total = 0
    try:
        bar = tqdm(
            plan.episodes, desc="export", unit="episode", file=sys.stderr, disable=not progress
        )
        for i, ep in enumerate(bar):
            columns, image_index = frame_columns(ep, plan, i, total)
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
