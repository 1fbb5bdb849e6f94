"""gzip compression of image frames off the render path.

:class:`ChunkCompressor` hands each frame to a pool of threads that compress it (releasing
the GIL) and writes the finished bytes, in submission order, with ``write_direct_chunk`` from
the caller's thread, instead of h5py's filter compressing on the rendering thread. The
datasets carry the standard HDF5 deflate filter, so any HDF5 reader decodes them. Level 1
(the default) uses ISA-L's deflate (``isal``) where installed: the same zlib stream, the same
size, a quarter of the CPU time; other levels use :func:`zlib.compress`. Each dataset must be
chunked one frame per chunk, ``(1, H, W, 3)``, and created with ``compression="gzip"``.

Docs: docs/datasets.md; measurements: docs/benchmarks.md; why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import zlib
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor

import h5py
import numpy as np

from trossen_arm_mujoco.processes import available_cpus

__all__ = ["ChunkCompressor", "default_workers", "deflate_function", "write_chunk"]

#: Filter mask of a chunk stored without its (only, optional) deflate filter.
_SKIP_DEFLATE = 0x1


def default_workers() -> int:
    """Compression threads: one per CPU this process may use, at most 4 (zlib level 1 keeps up
    with that)."""
    return min(4, available_cpus())


try:
    from isal import isal_zlib
except ImportError:  # not installed: zlib for every level
    isal_zlib = None


def deflate_function(level: int):
    """The function ``(bytes-like, level) -> zlib stream`` used for ``level``: ISA-L's
    ``isal_zlib.compress`` for level 1 when ``isal`` is installed, else ``zlib.compress``."""
    return isal_zlib.compress if level == 1 and isal_zlib is not None else zlib.compress


def _compress(frame: np.ndarray, level: int, deflate=None) -> tuple[bytes, int]:
    """(chunk bytes, filter mask) of one frame; ``deflate``: ``deflate_function(level)``,
    looked up once by the caller (default: looked up here)."""
    data = (deflate or deflate_function(level))(frame, level)
    if len(data) >= frame.nbytes:  # incompressible: store raw, as the deflate filter does
        return frame.tobytes(), _SKIP_DEFLATE
    return data, 0


def write_chunk(dataset: h5py.Dataset, offset: tuple[int, ...], data: bytes, mask: int) -> None:
    """Store finished chunk bytes at chunk ``offset`` of ``dataset``.

    Args:
        dataset: a chunked HDF5 dataset with the deflate filter.
        offset: the chunk's first element, in element coordinates (e.g. ``(t, 0, 0, 0)``).
        data: the chunk's bytes as the filter stores them.
        mask: the filter mask (1: the deflate filter skipped, the bytes raw).
    """
    dataset.id.write_direct_chunk(offset, data, filter_mask=mask)


class ChunkCompressor:
    """Compress frames in threads, write them as chunks in submission order.

    Args:
        level: zlib level 1..9.
        workers: compression threads (default :func:`default_workers`).
        max_pending: frames compressed or waiting at most; :meth:`submit` blocks on the
            oldest beyond that, so memory stays at ``max_pending`` frames.

    Use :meth:`submit` per frame, :meth:`flush` before closing the file, and
    :meth:`close` (or :meth:`cancel` on failure) at the end.
    """

    def __init__(self, level: int, workers: int | None = None, max_pending: int | None = None):
        if not 1 <= int(level) <= 9:
            raise ValueError(f"zlib level must be 1..9, got {level}")
        self.level = int(level)
        self._deflate = deflate_function(self.level)  # chosen once, not per frame
        self.workers = default_workers() if workers is None else max(1, int(workers))
        self.max_pending = max_pending or 4 * self.workers + 4
        self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="chunk-gzip")
        self._pending: deque[tuple[h5py.Dataset, int, Future[tuple[bytes, int]]]] = deque()

    def submit(self, dataset: h5py.Dataset, index: int, frame: np.ndarray) -> None:
        """Queue a frame and write every chunk finished so far.

        Args:
            dataset: the image dataset, chunked ``(1, H, W, 3)``.
            index: the frame's step ``t``.
            frame: uint8 ``(H, W, 3)``; copied, so the caller may reuse it.

        Raises:
            OSError / RuntimeError from h5py when a chunk cannot be written.
        """
        frame = np.array(frame, dtype=np.uint8, order="C", copy=True)
        future = self._pool.submit(_compress, frame, self.level, self._deflate)
        self._pending.append((dataset, index, future))
        self._write_ready(block=len(self._pending) > self.max_pending)

    def _write_ready(self, block: bool) -> None:
        while self._pending and (block or self._pending[0][2].done()):
            dataset, index, future = self._pending[0]
            data, mask = future.result()
            write_chunk(dataset, (index,) + (0,) * (dataset.ndim - 1), data, mask)
            self._pending.popleft()
            block = block and len(self._pending) > self.max_pending

    def flush(self) -> None:
        """Wait for every queued frame and write it."""
        while self._pending:
            self._write_ready(block=True)

    def cancel(self) -> None:
        """Drop queued frames without writing them and stop the threads (idempotent)."""
        for _, _, future in self._pending:
            future.cancel()
        self._pending.clear()
        self._pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        """Write what is queued, then stop the threads."""
        try:
            self.flush()
        finally:
            self.cancel()
