"""Episode files: the HDF5 schema, streaming atomic writing, validated loading, videos.

Videos and plots (:mod:`.video`) need the ``video`` extra (PyAV, matplotlib), imported
only when a video or plot is made.

Docs: docs/datasets.md.
"""

from trossen_arm_mujoco.data.io_errors import EpisodeIOError, EpisodeWriteError
from trossen_arm_mujoco.data.reader import (
    Episode,
    EpisodeError,
    FrameReader,
    episode_path,
    iter_episodes,
    list_episodes,
    load_episode,
    resolve_data_dir,
)
from trossen_arm_mujoco.data.schema import (
    NUM_JOINTS,
    SCHEMA,
    SCHEMA_VERSION,
    EpisodeSchema,
)
from trossen_arm_mujoco.data.temp_files import remove_stale_temp_files
from trossen_arm_mujoco.data.video import plot_joints, write_episode_video
from trossen_arm_mujoco.data.writer import EpisodeWriter

__all__ = [
    "NUM_JOINTS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "Episode",
    "EpisodeError",
    "EpisodeIOError",
    "EpisodeSchema",
    "EpisodeWriteError",
    "EpisodeWriter",
    "FrameReader",
    "episode_path",
    "iter_episodes",
    "list_episodes",
    "load_episode",
    "plot_joints",
    "remove_stale_temp_files",
    "resolve_data_dir",
    "write_episode_video",
]
