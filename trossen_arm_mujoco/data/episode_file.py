"""The HDF5 file of one episode while it is written, and its atomic publication.

``EpisodeFile`` creates a temporary sibling of the final file (``temp_files``) with the
datasets of the episode layout (:mod:`.schema`) preallocated for ``episode_len`` steps, and
writes one step's rows at a time (images optionally gzip-compressed in background threads,
:mod:`.chunk_compressor`). ``commit`` writes the root attributes, reads the file back with
the reader's validation and renames it onto the final name (``fileio.publish``). On any
failure the temporary file is deleted; a refused write raises a one-line
:class:`~.io_errors.EpisodeIOError`. What is written is :class:`~.writer.EpisodeWriter`'s.

Docs: docs/datasets.md.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from trossen_arm_mujoco.data.chunk_compressor import ChunkCompressor
from trossen_arm_mujoco.data.io_errors import (
    IO_ERRORS,
    EpisodeWriteError,
    discard_file,
    io_error,
)
from trossen_arm_mujoco.data.schema import SCHEMA
from trossen_arm_mujoco.data.temp_files import unique_temp_path
from trossen_arm_mujoco.fileio import publish

__all__ = ["EpisodeFile"]


class EpisodeFile:
    """The temporary HDF5 file of one episode, published whole or not at all.

    Args:
        path: the final file, normally ``<folder>/episode_<k>.hdf5``.
        episode_len: steps ``T`` the datasets hold.
        widths: per-step shape of every numeric dataset of ``SCHEMA.array_names``.
        camera_names: cameras with an image dataset (``(T, height, width, 3)`` uint8).
        height, width: image size in pixels.
        compression: ``"none"`` | ``"gzip"`` (level ``gzip_level``, in ``compress_workers``
            background threads) | ``"lzf"``, for the image datasets.
        create_folder: create the folder of ``path`` when missing (else a missing folder is
            an ``EpisodeIOError``).

    Raises:
        EpisodeIOError: the file system refused to create the file (nothing is left behind).
    """

    def __init__(
        self,
        path: Path,
        episode_len: int,
        widths: Mapping[str, tuple[int, ...]],
        camera_names: Sequence[str],
        height: int,
        width: int,
        compression: str,
        gzip_level: int,
        compress_workers: int | None,
        create_folder: bool,
    ) -> None:
        self.path = path
        self.temp_path = unique_temp_path(path)
        self.episode_len = episode_len
        self.camera_names = list(camera_names)
        self._file: h5py.File | None = None
        self._compressor: ChunkCompressor | None = None
        with self._discarded_on_error():
            if create_folder:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = h5py.File(self.temp_path, "w")
            self._create_datasets(widths, height, width, compression, gzip_level, compress_workers)

    @contextmanager
    def _discarded_on_error(self) -> Iterator[None]:
        """Any error inside discards the temporary file; OS errors become one-line
        ``EpisodeIOError``s naming the episode."""
        try:
            yield
        except IO_ERRORS as exc:
            self.discard()
            raise io_error(self.path, exc) from exc
        except BaseException:
            self.discard()
            raise

    def _create_datasets(
        self,
        widths: Mapping[str, tuple[int, ...]],
        height: int,
        width: int,
        compression: str,
        gzip_level: int,
        workers: int | None,
    ) -> None:
        assert self._file is not None
        kwargs: dict[str, Any] = {}
        if compression == "gzip":
            kwargs = {"compression": "gzip", "compression_opts": gzip_level}
            if self.camera_names:
                self._compressor = ChunkCompressor(gzip_level, workers)
        elif compression == "lzf":
            kwargs = {"compression": "lzf"}
        self._arrays = {
            name: self._file.create_dataset(
                spec.path, shape=(self.episode_len, *widths[name]), dtype=spec.dtype
            )
            for name, spec in zip(SCHEMA.array_names, SCHEMA.arrays, strict=True)
        }
        self._file.require_group(SCHEMA.image_group)
        self._images = {
            cam: self._file.create_dataset(
                SCHEMA.image_path(cam),
                shape=SCHEMA.image_shape(self.episode_len, height, width),
                dtype=SCHEMA.image_dtype,
                chunks=SCHEMA.image_chunks(height, width),
                **kwargs,
            )
            for cam in self.camera_names
        }

    @property
    def closed(self) -> bool:
        """True once the file was committed or discarded."""
        return self._file is None

    def write_step(
        self, t: int, arrays: Mapping[str, np.ndarray], frames: Mapping[str, np.ndarray]
    ) -> None:
        """Write one step's rows.

        Args:
            t: the step index (row).
            arrays: dataset path -> the step's values, checked, of the datasets' dtypes.
            frames: camera name -> uint8 (H, W, 3) image.
        """
        with self._discarded_on_error():
            for name, value in arrays.items():
                self._arrays[name][t] = value
            for cam, frame in frames.items():
                if self._compressor is not None:
                    self._compressor.submit(self._images[cam], t, frame)
                else:
                    self._images[cam][t] = frame

    def commit(self, attrs: Mapping[str, Any], verify: bool, overwrite: bool) -> None:
        """Write the root attributes, flush, close, read back and rename onto ``path``.

        Args:
            attrs: the root attributes.
            verify: read the file back with the reader's validation before the rename.
            overwrite: replace a file already at ``path``.

        Raises:
            EpisodeWriteError: the file does not read back, or the final file appeared
                meanwhile (no overwrite).
            EpisodeIOError: the file system refused a write.
            The temporary file is deleted in every failure case.
        """
        assert self._file is not None
        try:
            try:
                if self._compressor is not None:
                    self._compressor.close()
                    self._compressor = None
                for name, value in attrs.items():
                    self._file.attrs[name] = value
                self._file.flush()
                self._file.close()
                self._file = None
                if verify:
                    self._verify()
                publish(self.temp_path, self.path, overwrite=overwrite)
            except FileExistsError:
                raise EpisodeWriteError(
                    f"{self.path} appeared while writing; refusing to overwrite it"
                ) from None
            except IO_ERRORS as exc:
                raise io_error(self.path, exc) from exc
        except BaseException:
            self.discard()
            raise

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

    def discard(self) -> None:
        """Close and delete the temporary file (idempotent, never raises an I/O error: on a
        read-only file system there is nothing more to do)."""
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
