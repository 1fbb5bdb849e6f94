"""Streaming, atomic writing of one episode file (layout in :mod:`.schema`).

Each :meth:`EpisodeWriter.append` checks one step (shapes, finite values, the cameras'
images) and writes it into preallocated datasets of a temporary file next to the final one
(:mod:`.episode_file`), so memory stays flat whatever the episode length. The temporary file
becomes ``episode_<k>.hdf5`` only after all steps are written, fsynced and read back; on any
error it is deleted, so a folder never holds a half-written episode. Images are
gzip-compressed in background threads (:mod:`.chunk_compressor`). A write the file system
refuses raises :class:`EpisodeIOError` (one line naming the file and the cause).

Docs: docs/datasets.md.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.data.episode_file import EpisodeFile
from trossen_arm_mujoco.data.io_errors import EpisodeWriteError
from trossen_arm_mujoco.data.schema import (
    COMPRESSIONS,
    DEFAULT_COMPRESSION,
    ENV_STATE_DIM,
    GZIP_LEVEL,
    JOINT_ARRAYS,
    SCHEMA,
    encode_attr,
    joint_width,
)
from trossen_arm_mujoco.data.schema import VENDOR_DT as DT

__all__ = ["EpisodeWriter", "package_version"]

#: Attributes that follow from the writer's arguments; callers may not change them.
_WRITER_ATTRS = frozenset({"sim", "episode_len", "camera_names", "schema_version"})


def package_version() -> str:
    """Installed version of trossen-arm-mujoco, ``"unknown"`` when not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("trossen-arm-mujoco")
    except PackageNotFoundError:
        return "unknown"


def _mujoco_version() -> str:
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is a core dependency
        return "unknown"
    return str(mujoco.__version__)


class EpisodeWriter:
    """Write one episode, one step at a time, atomically.

    Usage::

        with EpisodeWriter(path, episode_len=600, camera_names=cams, height=480, width=640,
                           attrs={"task_name": "sim_transfer_cube", "seed": 3,
                                  "box_pose": pose}) as w:
            for t in range(600):
                w.append(qpos, qvel, action, reward, env_state, images)
            w.set_attrs(success=True)
        # the file exists under ``path`` only now

    Args:
        path: final file, normally ``<folder>/episode_<k>.hdf5``.
        episode_len: number of steps ``T`` the episode will have; exactly ``T`` appends.
        camera_names: cameras whose images every step carries (may be empty).
        height, width: image size in pixels (480, 640 at documented settings).
        compression: ``"none"`` | ``"gzip"`` (default; level ``GZIP_LEVEL``, compressed in
            background threads) | ``"lzf"``, for the image datasets.
        env_state_dim: values per step of ``env_state`` (7 per object of the task).
        attrs: root attributes; ``task_name``, ``seed`` and ``success`` must be
            set before :meth:`close` (here or with :meth:`set_attrs`).
        verify: before the rename, read the finished file back with the reader's
            validation (:func:`~.reader.load_episode`); a file that does not read back is
            discarded with an :class:`EpisodeWriteError`.
        overwrite: replace an existing final file instead of refusing.
        create_folder: create the folder of ``path`` when missing; with False a missing
            folder is an :class:`EpisodeIOError` (the recorder: a folder removed during a
            run is reported, not silently recreated).
        compress_workers: gzip threads (default: one per CPU, at most 4).
        gzip_level: zlib level 1..9 of ``"gzip"`` (default ``GZIP_LEVEL``).

    Raises:
        EpisodeWriteError: invalid arguments, an existing file (no overwrite) or a folder
            at ``path`` (never replaced); its ``cli_message`` says what to do in a command.
        EpisodeIOError: the file system refused a write, here or in :meth:`append` /
            :meth:`close`; the temporary file is removed.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        episode_len: int,
        camera_names: Iterable[str] = (),
        height: int = 480,
        width: int = 640,
        compression: str = DEFAULT_COMPRESSION,
        attrs: Mapping[str, Any] | None = None,
        overwrite: bool = False,
        env_state_dim: int = ENV_STATE_DIM,
        create_folder: bool = True,
        compress_workers: int | None = None,
        gzip_level: int = GZIP_LEVEL,
        verify: bool = True,
    ) -> None:
        self.path = Path(path).expanduser()
        if int(env_state_dim) < 1 or int(env_state_dim) % ENV_STATE_DIM:
            raise EpisodeWriteError(
                f"env_state_dim must be a positive multiple of {ENV_STATE_DIM} (7 values per "
                f"object), got {env_state_dim}"
            )
        #: Per-step shape of every numeric dataset (``env_state`` chosen per episode; the
        #: joint arrays as wide as the ``layout`` attribute says, ``schema.joint_width``).
        joints = (joint_width((attrs or {}).get("layout")),)
        self.widths = {
            name: (int(env_state_dim),) if spec.variable else spec.width
            for name, spec in zip(SCHEMA.array_names, SCHEMA.arrays, strict=True)
        }
        self.widths.update({name: joints for name in JOINT_ARRAYS})
        self.verify = verify
        self.episode_len = int(episode_len)
        self.camera_names = list(camera_names)
        self.height, self.width = int(height), int(width)
        self.overwrite = overwrite
        self.num_steps = 0
        self._committed = False
        if self.episode_len < 1:
            raise EpisodeWriteError(f"episode_len must be at least 1, got {episode_len}")
        if compression not in COMPRESSIONS:
            raise EpisodeWriteError(
                f"unknown compression '{compression}'; valid: {', '.join(COMPRESSIONS)}"
            )
        if isinstance(gzip_level, bool) or gzip_level not in range(1, 10):
            raise EpisodeWriteError(f"gzip_level must be an int in 1..9, got {gzip_level!r}")
        self.gzip_level = int(gzip_level)
        bad = [
            cam for cam in self.camera_names if not isinstance(cam, str) or not cam or "/" in cam
        ]
        if bad:
            raise EpisodeWriteError(f"invalid camera names {bad}: use non-empty names without '/'")
        if len(set(self.camera_names)) != len(self.camera_names):
            raise EpisodeWriteError(f"duplicate camera names: {self.camera_names}")
        if self.camera_names and (self.height < 1 or self.width < 1):
            raise EpisodeWriteError(f"image size must be positive, got {height}x{width}")
        if self.path.is_dir():  # overwrite or not: a folder is never replaced
            raise EpisodeWriteError(
                f"{self.path} is a folder, not an episode file; refusing to replace it",
                hint="move it out of the folder or choose another episode index",
                cli_hint="move it out of the dataset folder (or delete it) and rerun",
            )
        if self.path.exists() and not overwrite:
            raise EpisodeWriteError(
                f"{self.path} already exists; refusing to overwrite it",
                hint="pass overwrite=True or choose another episode index",
                cli_hint="move it out of the dataset folder and rerun (with record, "
                "--overwrite records the whole dataset afresh)",
            )
        defaults = {
            "sim": True,
            "episode_len": self.episode_len,
            "dt": DT,
            "camera_names": list(self.camera_names),
            "package_version": package_version(),
            "mujoco_version": _mujoco_version(),
            "schema_version": SCHEMA.version,
        }
        self._attrs: dict[str, Any] = {}
        self.set_attrs(**defaults)
        self.set_attrs(**dict(attrs or {}))
        self._episode = EpisodeFile(
            self.path,
            self.episode_len,
            self.widths,
            self.camera_names,
            self.height,
            self.width,
            compression,
            self.gzip_level,
            compress_workers,
            create_folder,
        )
        #: The temporary file the steps go to until ``close``.
        self.temp_path = self._episode.temp_path

    def __enter__(self) -> EpisodeWriter:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    @property
    def closed(self) -> bool:
        """True once the episode was committed or aborted."""
        return self._episode.closed

    def set_attrs(self, **attrs: Any) -> None:
        """Set root attributes (validated now, written on :meth:`close`)."""
        for name, value in attrs.items():
            try:
                encoded = encode_attr(name, value)
            except ValueError as exc:
                raise EpisodeWriteError(str(exc)) from None
            if name in _WRITER_ATTRS and name in self._attrs:
                if not np.array_equal(np.asarray(encoded), np.asarray(self._attrs[name])):
                    raise EpisodeWriteError(
                        f"attribute '{name}' is set by the writer "
                        f"({np.asarray(self._attrs[name]).tolist()!r}); "
                        f"got {value!r:.80}"
                    )
            if name == "layout" and (joint_width(value),) != self.widths["qpos"]:
                raise EpisodeWriteError(
                    f"attribute 'layout' {value!r:.40} has {joint_width(value)} joint values, "
                    f"but the writer was made for {self.widths['qpos'][0]}; pass it in attrs="
                )
            self._attrs[name] = encoded

    def append(
        self,
        qpos: Any,
        qvel: Any,
        action: Any,
        reward: float,
        env_state: Any,
        images: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        """Write one step.

        Args:
            qpos, qvel, action: 16 finite values each (rad, rad/s for joints; m, m/s fingers);
                7 for a single arm's recording (attribute ``layout`` ``"widowxai"``).
            reward: finite scalar.
            env_state: ``env_state_dim`` finite values, object poses xyz (m) + quat wxyz.
            images: ``{camera: uint8 (H, W, 3)}`` for exactly the writer's cameras.
        """
        if self.closed:
            raise EpisodeWriteError(f"writer for {self.path} is already closed")
        t = self.num_steps
        if t >= self.episode_len:
            raise EpisodeWriteError(
                f"{self.path.name}: all {self.episode_len} steps were already appended"
            )
        values = {"qpos": qpos, "qvel": qvel, "action": action, "reward": reward}
        values["env_state"] = env_state
        checked = {name: self._check_array(name, values[name], t) for name in self.widths}
        frames = self._check_images(images or {}, t)
        self._episode.write_step(t, checked, frames)  # discards the file if it fails
        self.num_steps = t + 1

    def _check_array(self, name: str, value: Any, t: int) -> np.ndarray:
        spec = SCHEMA.array(name)
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise EpisodeWriteError(
                f"step {t}: {name} must be numeric, got {type(value).__name__}"
            ) from None
        if arr.shape != self.widths[name]:
            raise EpisodeWriteError(
                f"step {t}: {name} has shape {arr.shape}, expected {self.widths[name]}"
            )
        if not np.all(np.isfinite(arr)):
            raise EpisodeWriteError(f"step {t}: {name} contains NaN or inf: {arr.tolist()}")
        stored = arr.astype(spec.dtype)
        if not np.all(np.isfinite(stored)):
            raise EpisodeWriteError(
                f"step {t}: {name} has values beyond the {spec.dtype} range: {arr.tolist()}"
            )
        return stored

    def _check_images(self, images: Mapping[str, np.ndarray], t: int) -> dict[str, np.ndarray]:
        if set(images) != set(self.camera_names):
            raise EpisodeWriteError(
                f"step {t}: images for cameras {sorted(images)}, expected {self.camera_names}"
            )
        want = (self.height, self.width, 3)
        for cam, frame in images.items():
            shape = getattr(frame, "shape", None)
            dtype = getattr(frame, "dtype", None)
            if shape != want or dtype != SCHEMA.image_dtype:
                raise EpisodeWriteError(
                    f"step {t}: image '{cam}' is {dtype} {shape}, expected uint8 {want}"
                )
        return dict(images)

    def close(self) -> Path:
        """Commit: write attributes, flush, fsync and rename onto the final name.

        Returns:
            The final path.

        Raises:
            EpisodeWriteError: fewer than ``episode_len`` steps were appended, a required
                attribute is missing, or the final file appeared meanwhile (no overwrite).
                The temporary file is deleted in every failure case.
        """
        if self.closed:
            if self._committed:
                return self.path
            raise EpisodeWriteError(f"writer for {self.path} was aborted")
        try:
            if self.num_steps != self.episode_len:
                raise EpisodeWriteError(
                    f"{self.path.name}: only {self.num_steps} of {self.episode_len} steps "
                    "were appended; episode discarded"
                )
            missing = [name for name in SCHEMA.attrs if name not in self._attrs]
            if missing:
                raise EpisodeWriteError(
                    f"{self.path.name}: missing attributes {missing}; pass them in attrs= "
                    "or set_attrs()"
                )
            self._episode.commit(self._attrs, self.verify, self.overwrite)
        except BaseException:
            self.abort()
            raise
        self._committed = True
        return self.path

    def abort(self) -> None:
        """Discard the episode: close and delete the temporary file (idempotent, never
        raises an I/O error: on a read-only file system there is nothing more to do)."""
        self._episode.discard()
