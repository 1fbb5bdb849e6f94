"""The LeRobot v3.0 dataset layout, defined once: paths, feature specs, ``meta/`` files.

A dataset folder holds ``meta/info.json``, ``meta/stats.json``, ``meta/tasks.parquet``,
``meta/episodes/chunk-000/file-000.parquet`` (one row per episode),
``data/chunk-CCC/file-FFF.parquet`` (one row per frame, one row group per episode) and
``videos/<video_key>/chunk-CCC/file-FFF.mp4`` (per camera, the episodes one after the other).
Vector features are fixed-size lists of float32; features of shape (1,) are plain columns.
Joint vectors are in a layout of ``robot.layout.EXPORT_LAYOUTS``; ``robot_type`` is the
plugin's robot of the layout (:data:`ROBOT_TYPES`). Files grow up to a size limit (100 MB
data, 200 MB video), then the next starts; ``chunks_size`` files make a chunk folder.

Docs: docs/datasets.md (The LeRobot export); the file tree: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.export.deps import require
from trossen_arm_mujoco.robot.layout import EXPORT_LAYOUTS, VENDOR16_LAYOUT
from trossen_arm_mujoco.robot.lerobot_keys import (
    ACTION_KEY,
    ENV_STATE_KEY,
    STATE_KEY,
    VELOCITY_KEY,
    image_key,
    with_quantity,
)

__all__ = [
    "CHUNKS_SIZE",
    "CODEBASE_VERSION",
    "DATA_FILES_SIZE_MB",
    "DATA_PATH",
    "ENV_STATE_KEY",
    "EPISODES_PATH",
    "INDEX_FEATURES",
    "INFO_PATH",
    "QUANTILES",
    "MOBILE_ROBOT_TYPE",
    "ROBOT_TYPE",
    "ROBOT_TYPES",
    "SIM_FEATURES",
    "STATS_PATH",
    "STAT_NAMES",
    "TASKS_PATH",
    "VECTOR_FEATURES",
    "VIDEO_FILES_SIZE_MB",
    "VIDEO_PATH",
    "FileIndex",
    "build_features",
    "build_info",
    "data_schema",
    "layout_values",
    "video_key",
    "write_episodes",
    "write_json",
    "write_tasks",
]

#: Format version LeRobot checks when loading.
CODEBASE_VERSION = "v3.0"
#: Files per chunk folder, and the size (MB) at which data / video files roll over.
CHUNKS_SIZE = 1000
DATA_FILES_SIZE_MB = 100
VIDEO_FILES_SIZE_MB = 200

DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"

#: ``robot_type`` of info.json per layout: the name of Trossen's LeRobot plugin robot whose
#: ``lerobot-record`` writes that layout (``vendor16``, the files' own, is no plugin robot's).
ROBOT_TYPES: dict[str, str] = {
    "kit14": "bi_widowxai_follower_robot",
    "mobileai": "mobileai_robot",
    "widowxai": "widowxai_follower_robot",
    "vendor16": "trossen_ai_stationary",
}
#: The Stationary AI kit's and the Mobile AI's robot types.
ROBOT_TYPE = ROBOT_TYPES["kit14"]
MOBILE_ROBOT_TYPE = ROBOT_TYPES["mobileai"]

#: Joint vector features (in the export's layout): key -> the Episode attribute they hold.
VECTOR_FEATURES: dict[str, str] = {
    ACTION_KEY: "action",
    STATE_KEY: "qpos",
    VELOCITY_KEY: "qvel",
}
#: Features only ``sim_features`` exports add (the simulation's, not ``lerobot-record``'s).
SIM_FEATURES: tuple[str, ...] = (VELOCITY_KEY, ENV_STATE_KEY, "next.reward", "next.success")
#: Per-frame bookkeeping columns every LeRobot dataset has.
INDEX_FEATURES: dict[str, str] = {
    "timestamp": "float32",
    "frame_index": "int64",
    "episode_index": "int64",
    "index": "int64",
    "task_index": "int64",
}
#: Statistics stored per feature, in this order.
QUANTILES: tuple[float, ...] = (0.01, 0.10, 0.50, 0.90, 0.99)
STAT_NAMES: tuple[str, ...] = ("min", "max", "mean", "std", "count") + tuple(
    f"q{round(q * 100):02d}" for q in QUANTILES
)


#: Feature key of a camera: ``observation.images.<camera>`` (``robot.lerobot_keys``).
video_key = image_key


@dataclass(frozen=True)
class FileIndex:
    """Which file of a sequence: ``chunk-<chunk>/file-<file>``."""

    chunk: int = 0
    file: int = 0

    def next(self, chunks_size: int = CHUNKS_SIZE) -> FileIndex:
        """The following file: the next number, or file 0 of the next chunk when full."""
        if self.file + 1 >= chunks_size:
            return FileIndex(self.chunk + 1, 0)
        return FileIndex(self.chunk, self.file + 1)

    def path(self, template: str, **keys: str) -> str:
        """``template`` filled in (``DATA_PATH``, ``VIDEO_PATH`` with ``video_key=``...)."""
        return template.format(chunk_index=self.chunk, file_index=self.file, **keys)


def layout_values(layout: str, values: np.ndarray) -> np.ndarray:
    """``(..., 16)`` values of the HDF5 files in ``layout`` (a key of ``EXPORT_LAYOUTS``)."""
    target = EXPORT_LAYOUTS[layout]
    return np.asarray(values) if target is VENDOR16_LAYOUT else target.from_vendor(values)


def _vector(names: list[str]) -> dict[str, Any]:
    return {"dtype": "float32", "shape": [len(names)], "names": list(names)}


def build_features(
    image_shapes: dict[str, tuple[int, int, int]],
    video_info: dict[str, dict[str, Any]],
    with_reward: bool,
    layout: str = "kit14",
    env_names: list[str] | None = None,
    state_names: list[str] | None = None,
    sim_features: bool = False,
) -> dict[str, dict[str, Any]]:
    """The ``features`` of info.json, in column order (the module docstring's).

    Args:
        image_shapes: ``{camera: (H, W, 3)}`` in recording order (empty: no videos).
        video_info: ``{camera: info}``, the ``info`` block of each video feature (codec,
            pix_fmt, fps...).
        with_reward: the episodes have rewards (``next.reward`` float32 and ``next.success``
            bool with ``sim_features``).
        layout: joint layout of state, velocity and action (a key of ``EXPORT_LAYOUTS``): its
            size and names.
        env_names: names of the ``observation.environment_state`` values (None: no such
            feature; written with ``sim_features`` only).
        state_names: names of the ``observation.state`` values when they are more than the
            layout's positions (``export.lerobot_state``: with velocities, efforts).
        sim_features: add the simulation's features (:data:`SIM_FEATURES`).
    """
    names = list(EXPORT_LAYOUTS[layout].names)
    features: dict[str, dict[str, Any]] = {
        ACTION_KEY: _vector(names),
        STATE_KEY: _vector(names if state_names is None else list(state_names)),
    }
    for cam, (h, w, c) in image_shapes.items():
        features[video_key(cam)] = {
            "dtype": "video",
            "shape": [h, w, c],
            "names": ["height", "width", "channels"],
            "info": dict(video_info[cam]),
        }
    if sim_features:
        # velocities are named after their joints with a ".vel" suffix ("left_joint_0.vel")
        features[VELOCITY_KEY] = _vector(with_quantity(names, "vel"))
        if env_names is not None:
            features[ENV_STATE_KEY] = _vector(env_names)
    if with_reward and sim_features:
        features["next.reward"] = {"dtype": "float32", "shape": [1], "names": None}
        features["next.success"] = {"dtype": "bool", "shape": [1], "names": None}
    for key, dtype in INDEX_FEATURES.items():
        features[key] = {"dtype": dtype, "shape": [1], "names": None}
    return features


def build_info(
    features: dict[str, dict[str, Any]],
    fps: int,
    total_episodes: int,
    total_frames: int,
    total_tasks: int,
    layout: str = "kit14",
) -> dict[str, Any]:
    """The content of ``meta/info.json``.

    Args:
        features: feature key -> spec (``dtype``, ``shape``, ``names``), as :func:`build_features`
            builds them.
        fps: frames per second written.
        total_episodes: number of episodes.
        total_frames: number of frames, all episodes together.
        total_tasks: number of distinct task descriptions.
        layout: the joint layout; ``robot_type`` is its plugin robot (:data:`ROBOT_TYPES`).

    Returns:
        The JSON-ready dict.
    """
    has_video = any(ft["dtype"] == "video" for ft in features.values())
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": ROBOT_TYPES[layout],
        "fps": int(fps),
        "features": features,
        "total_episodes": int(total_episodes),
        "total_frames": int(total_frames),
        "total_tasks": int(total_tasks),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILES_SIZE_MB,
        "video_files_size_in_mb": VIDEO_FILES_SIZE_MB,
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if has_video else None,
        "splits": {"train": f"0:{int(total_episodes)}"},
    }


def data_schema(features: dict[str, dict[str, Any]]) -> Any:
    """The pyarrow schema of the frame parquet files (every non-video feature)."""
    pa = require("pyarrow")
    scalar = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}
    fields = []
    for key, ft in features.items():
        if ft["dtype"] == "video":
            continue
        kind = scalar[ft["dtype"]]
        shape = list(ft["shape"])
        fields.append(pa.field(key, kind if shape == [1] else pa.list_(kind, shape[0])))
    return pa.schema(fields)


def write_tasks(path: Path, tasks: list[str]) -> None:
    """``meta/tasks.parquet``: column ``task_index`` and the task strings as the index.

    LeRobot reads it with pandas and looks tasks up by index, so the file carries the pandas
    metadata that makes ``task`` the index (written here without needing pandas).
    """
    pa = require("pyarrow")
    pq = require("pyarrow.parquet", "pyarrow")
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": "task",
                "field_name": "task",
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": None,
            },
        ],
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.0",
    }
    schema = pa.schema(
        [pa.field("task_index", pa.int64()), pa.field("task", pa.string())],
        metadata={"pandas": json.dumps(pandas_meta)},
    )
    table = pa.table({"task_index": list(range(len(tasks))), "task": list(tasks)}, schema=schema)
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path, compression="snappy")


def write_episodes(path: Path, rows: list[dict[str, Any]]) -> None:
    """``meta/episodes/...parquet``: one row per episode (columns as in the rows' keys)."""
    pa = require("pyarrow")
    pq = require("pyarrow.parquet", "pyarrow")
    columns = {key: [row[key] for row in rows] for key in rows[0]}
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table(columns), path, compression="snappy")


def write_json(path: Path, content: dict[str, Any]) -> None:
    """Write ``content`` as indented JSON."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(content, indent=4) + "\n", encoding="utf-8")
