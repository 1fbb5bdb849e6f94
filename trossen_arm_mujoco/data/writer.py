"""Streaming, atomic writing of one episode file (layout in :mod:`.schema`).

Each :meth:`EpisodeWriter.append` writes one step straight into preallocated datasets of a
temporary file next to the final one, so memory stays flat whatever the episode length.
The temporary file (``.episode_<k>.hdf5.<pid>-<random>.tmp``: unique, so two writers never
share one) becomes ``episode_<k>.hdf5`` only after all steps are written, flushed, fsynced
and read back with the reader's validation; on any error it is deleted, so a folder never
holds a half-written episode.

Images are gzip-compressed by default, in background threads
(:mod:`.chunk_compressor`), so compression stays off the render path. A write the file
system refuses (disk full, read-only or unwritable folder, folder removed meanwhile) raises
:class:`EpisodeIOError`, a one-line message naming the file and the cause.
"""

from __future__ import annotations

import errno
import os
import re
import secrets
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from trossen_arm_mujoco.data.chunk_compressor import ChunkCompressor
from trossen_arm_mujoco.data.io_errors import IO_ERRORS, discard_file, io_error
from trossen_arm_mujoco.data.schema import (
    COMPRESSIONS,
    DEFAULT_COMPRESSION,
    ENV_STATE_DIM,
    GZIP_LEVEL,
    SCHEMA,
    encode_attr,
    temp_file_name,
)
from trossen_arm_mujoco.data.schema import VENDOR_DT as DT
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import publish

#: Attributes that follow from the writer's arguments; callers may not change them.
_WRITER_ATTRS = frozenset({"sim", "episode_len", "camera_names", "schema_version"})

#: Temporary episode files: ``.<final>.tmp`` (older versions) or ``.<final>.<pid>-<hex>.tmp``.
_TEMP_RE = re.compile(r"^\.(?P<final>.+\.hdf5)(?:\.(?P<pid>[0-9]+)-[0-9a-f]+)?\.tmp$")


def unique_temp_path(path: Path) -> Path:
    """A temporary sibling of ``path`` that no other writer uses:
    ``.<name>.<pid>-<random>.tmp`` (hidden, never an episode name)."""
    base = temp_file_name(path.name)  # ".<name>.tmp"
    return path.with_name(f"{base[: -len('.tmp')]}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # this process: its own leftovers are stale when it cleans up
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by another user
        return True
    return True


class EpisodeWriteError(UserError):
    """Invalid data handed to the episode writer, or a refused write."""


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
        EpisodeWriteError: invalid arguments or an existing file (no overwrite).
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
        #: Per-step shape of every numeric dataset (``env_state`` chosen per episode).
        self.widths = {
            name: (int(env_state_dim),) if spec.variable else spec.width
            for name, spec in zip(SCHEMA.array_names, SCHEMA.arrays, strict=True)
        }
        self.temp_path = unique_temp_path(self.path)
        self.verify = verify
        self.episode_len = int(episode_len)
        self.camera_names = list(camera_names)
        self.height, self.width = int(height), int(width)
        self.overwrite = overwrite
        self.num_steps = 0
        self._committed = False
        self._file: h5py.File | None = None
        self._compressor: ChunkCompressor | None = None
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
        if self.path.exists() and not overwrite:
            raise EpisodeWriteError(
                f"{self.path} already exists; refusing to overwrite it (pass overwrite=True "
                "or choose another episode index)"
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
        try:
            if create_folder:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = h5py.File(self.temp_path, "w")
            self._create_datasets(compression, compress_workers)
        except IO_ERRORS as exc:
            self.abort()
            raise io_error(self.path, exc) from exc
        except BaseException:
            self.abort()
            raise

    def _create_datasets(self, compression: str, workers: int | None) -> None:
        assert self._file is not None
        kwargs: dict[str, Any] = {}
        if compression == "gzip":
            kwargs = {"compression": "gzip", "compression_opts": self.gzip_level}
            if self.camera_names:
                self._compressor = ChunkCompressor(self.gzip_level, workers)
        elif compression == "lzf":
            kwargs = {"compression": "lzf"}
        self._arrays = {}
        for name, spec in zip(SCHEMA.array_names, SCHEMA.arrays, strict=True):
            self._arrays[name] = self._file.create_dataset(
                spec.path, shape=(self.episode_len, *self.widths[name]), dtype=spec.dtype
            )
        self._file.require_group(SCHEMA.image_group)
        self._images = {
            cam: self._file.create_dataset(
                SCHEMA.image_path(cam),
                shape=SCHEMA.image_shape(self.episode_len, self.height, self.width),
                dtype=SCHEMA.image_dtype,
                chunks=SCHEMA.image_chunks(self.height, self.width),
                **kwargs,
            )
            for cam in self.camera_names
        }

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
        return self._file is None

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
            qpos, qvel, action: 16 finite values each (rad, rad/s for joints; m, m/s fingers).
            reward: finite scalar.
            env_state: ``env_state_dim`` finite values, object poses xyz (m) + quat wxyz.
            images: ``{camera: uint8 (H, W, 3)}`` for exactly the writer's cameras.
        """
        if self._file is None:
            raise EpisodeWriteError(f"writer for {self.path} is already closed")
        t = self.num_steps
        if t >= self.episode_len:
            raise EpisodeWriteError(
                f"{self.path.name}: all {self.episode_len} steps were already appended"
            )
        values = {"qpos": qpos, "qvel": qvel, "action": action, "reward": reward}
        values["env_state"] = env_state
        checked = {name: self._check_array(name, values[name], t) for name in self._arrays}
        frames = self._check_images(images or {}, t)
        try:
            for name, value in checked.items():
                self._arrays[name][t] = value
            for cam, frame in frames.items():
                if self._compressor is not None:
                    self._compressor.submit(self._images[cam], t, frame)
                else:
                    self._images[cam][t] = frame
        except IO_ERRORS as exc:
            self.abort()
            raise io_error(self.path, exc) from exc
        except BaseException:
            self.abort()
            raise
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
        if self._file is None:
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
            try:
                if self._compressor is not None:
                    self._compressor.close()
                    self._compressor = None
                for name, value in self._attrs.items():
                    self._file.attrs[name] = value
                self._file.flush()
                self._file.close()
                self._file = None
                if self.verify:
                    self._verify()
                publish(self.temp_path, self.path, overwrite=self.overwrite)
            except FileExistsError:
                raise EpisodeWriteError(
                    f"{self.path} appeared while writing; refusing to overwrite it"
                ) from None
            except IO_ERRORS as exc:
                raise io_error(self.path, exc) from exc
        except BaseException:
            self.abort()
            raise
        self._committed = True
        return self.path

    def _verify(self) -> None:
        """Read the closed temporary file back as the reader would."""
        from trossen_arm_mujoco.data.reader import EpisodeError, load_episode

        try:
            episode = load_episode(self.temp_path)
        except EpisodeError as exc:
            if not self.temp_path.exists():  # the folder (or the file) was removed meanwhile
                missing = FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT))
                raise io_error(self.path, missing) from None
            raise EpisodeWriteError(
                f"{self.path.name}: the written file does not read back ({exc}); episode discarded"
            ) from None
        if episode.num_steps != self.episode_len or episode.camera_names != self.camera_names:
            raise EpisodeWriteError(
                f"{self.path.name}: the written file reads back as {episode.num_steps} steps "
                f"of cameras {episode.camera_names}, expected {self.episode_len} of "
                f"{self.camera_names}; episode discarded"
            )

    def abort(self) -> None:
        """Discard the episode: close and delete the temporary file (idempotent, never
        raises an I/O error: on a read-only file system there is nothing more to do)."""
        if self._compressor is not None:
            self._compressor.cancel()
            self._compressor = None
        if self._file is not None:
            discard_file(self._file)
            self._file = None
        try:
            self.temp_path.unlink(missing_ok=True)
        except OSError:
            pass


def remove_stale_temp_files(folder: str | os.PathLike[str]) -> list[Path]:
    """Delete temporary episode files left by interrupted or killed runs in ``folder``.

    Call it only while holding the folder's lock (:mod:`.dataset_lock`), so that no other
    run writes there. A file whose name carries the pid of a process that still runs (a
    writer outside any locked run) is left alone.

    Returns:
        The deleted paths (empty when the folder does not exist).
    """
    folder = Path(folder).expanduser()
    if not folder.is_dir():
        return []
    removed = []
    try:
        for path in sorted(folder.glob(".episode_*.hdf5*.tmp")):
            match = _TEMP_RE.match(path.name)
            if match is None:
                continue
            if match["pid"] is not None and _process_alive(int(match["pid"])):
                continue
            path.unlink(missing_ok=True)
            removed.append(path)
    except OSError:  # folder removed meanwhile, or read-only: nothing to clean
        pass
    return removed
