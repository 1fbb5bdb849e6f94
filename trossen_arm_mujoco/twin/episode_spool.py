"""The steps of one episode, kept until it ends, then published as an episode file.

A served or teleoperated episode lasts until its clients leave or its operator ends it, so
its length is known only at its end, while
:class:`~trossen_arm_mujoco.data.writer.EpisodeWriter` (the one writer of episode files:
schema, atomic publish, read-back check) wants it up front. An :class:`EpisodeSpool`
therefore keeps the steps meanwhile: the numbers in memory (a few hundred bytes a step), the
camera frames in a temporary HDF5 file in the dataset folder (uncompressed, growing a frame
at a time), so memory stays flat whatever the length. That file is named
``.serve_spool.<pid>-<random>.tmp`` (spools left by a killed run are removed by
:func:`remove_stale_spools`, under the dataset lock), or, with ``anonymous=True``, has no
name at all (an unnamed temporary file, gone when the process ends however it ends).
:meth:`EpisodeSpool.publish` then streams every step through an ``EpisodeWriter`` and
deletes the spool; :meth:`EpisodeSpool.discard` deletes it unpublished.
"""

from __future__ import annotations

import os
import re
import secrets
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.twin.frame import Frame

_SPOOL_RE = re.compile(r"^\.serve_spool\.(?P<pid>[0-9]+)-[0-9a-f]+\.tmp$")


def remove_stale_spools(folder: Path) -> list[Path]:
    """Delete spool files of processes that no longer run (call it holding the folder's
    lock); returns the deleted paths."""
    removed = []
    try:
        for path in folder.glob(".serve_spool.*.tmp"):
            match = _SPOOL_RE.match(path.name)
            if match is None or _alive(int(match["pid"])):
                continue
            path.unlink(missing_ok=True)
            removed.append(path)
    except OSError:
        pass
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


class EpisodeSpool:
    """Steps of one episode until it ends; see the module doc.

    Args:
        folder: the dataset folder (the image spool goes there, hidden).
        camera_names, height, width: the frames every step carries (none: no spool file).
        anonymous: keep the frames in an unnamed temporary file (no ``path``) rather than
            a named one.
    """

    def __init__(self, folder: Path, camera_names: Sequence[str], height: int, width: int,
                 anonymous: bool = False) -> None:  # fmt: skip
        self.folder, self.camera_names = Path(folder), list(camera_names)
        self.height, self.width = int(height), int(width)
        self.rows: dict[str, list[Any]] = {k: [] for k in ("qpos", "qvel", "action", "reward",
                                                           "env_state")}  # fmt: skip
        self.path: Path | None = None
        self._file: h5py.File | None = None
        self._unnamed: Any = None  # the unnamed temporary file behind ``_file``
        if self.camera_names and anonymous:
            self._unnamed = tempfile.TemporaryFile(dir=self.folder, prefix=".spool.")
            self._file = h5py.File(self._unnamed, "w")
        elif self.camera_names:
            name = f".serve_spool.{os.getpid()}-{secrets.token_hex(4)}.tmp"
            self.path = self.folder / name
            self._file = h5py.File(self.path, "w")
        if self._file is not None:
            shape, frame = (0, self.height, self.width, 3), (self.height, self.width, 3)
            for cam in self.camera_names:
                self._file.create_dataset(cam, shape=shape, maxshape=(None, *frame),
                                          chunks=(1, *frame), dtype=np.uint8)  # fmt: skip

    def __len__(self) -> int:
        return len(self.rows["reward"])

    @property
    def rewards(self) -> np.ndarray:
        """Rewards so far, (T,)."""
        return np.asarray(self.rows["reward"], dtype=np.float64)

    @property
    def actions(self) -> np.ndarray:
        """Actions so far, (T, action dim)."""
        return np.asarray(self.rows["action"], dtype=np.float64)

    def append(self, frame: Frame, images: Mapping[str, np.ndarray]) -> None:
        """One step: the frame's state, action and reward, and its camera images."""
        self.append_step(frame.qpos, frame.qvel, frame.action, frame.reward, frame.env_state,
                         images)  # fmt: skip

    def append_step(self, qpos: np.ndarray, qvel: np.ndarray, action: np.ndarray,
                    reward: float, env_state: np.ndarray,
                    images: Mapping[str, np.ndarray]) -> None:  # fmt: skip
        """One step: observation (``qpos``, ``qvel``, ``env_state``) before the action,
        the action, the reward after it, and the camera images (all copied)."""
        t = len(self)
        if self._file is not None:
            for cam in self.camera_names:
                data = self._file[cam]
                data.resize(t + 1, axis=0)
                data[t] = images[cam]
        rows = self.rows
        rows["qpos"].append(np.array(qpos))
        rows["qvel"].append(np.array(qvel))
        rows["action"].append(np.array(action))
        rows["reward"].append(float(reward))
        rows["env_state"].append(np.array(env_state))

    def publish(self, path: Path, attrs: Mapping[str, Any], compression: str) -> Path:
        """Write the episode to ``path`` through ``EpisodeWriter`` (never overwriting; the
        file appears only complete), then delete the spool. Raises what the writer raises
        (the spool is deleted either way)."""
        try:
            n = len(self)
            env_dim = len(self.rows["env_state"][0]) if n else 7
            with EpisodeWriter(
                path, episode_len=n, camera_names=self.camera_names, height=self.height,
                width=self.width, compression=compression, attrs=attrs,
                env_state_dim=env_dim, create_folder=False,
            ) as writer:  # fmt: skip
                for t in range(n):
                    images = {cam: self._file[cam][t] for cam in self.camera_names} if (
                        self._file is not None) else {}  # fmt: skip
                    writer.append(
                        qpos=self.rows["qpos"][t], qvel=self.rows["qvel"][t],
                        action=self.rows["action"][t], reward=self.rows["reward"][t],
                        env_state=self.rows["env_state"][t], images=images,
                    )  # fmt: skip
            return writer.path
        finally:
            self.discard()

    def discard(self) -> None:
        """Delete the spool (idempotent, never raises)."""
        for handle in (self._file, self._unnamed):  # the HDF5 file, then what it was on
            if handle is not None:
                try:
                    handle.close()
                except Exception:
                    pass
        self._file = self._unnamed = None
        if self.path is not None:
            try:
                self.path.unlink(missing_ok=True)
            except OSError:
                pass
            self.path = None
