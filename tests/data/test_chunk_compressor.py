"""gzip off the render path: chunks compressed in threads, readable by plain h5py."""

from __future__ import annotations

import errno
import threading
import zlib

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data import chunk_compressor
from trossen_arm_mujoco.data.chunk_compressor import ChunkCompressor

H, W = 24, 32


def _dataset(f: h5py.File, n: int, level: int = 1) -> h5py.Dataset:
    return f.create_dataset(
        "img",
        shape=(n, H, W, 3),
        dtype=np.uint8,
        chunks=(1, H, W, 3),
        compression="gzip",
        compression_opts=level,
    )


def _smooth_frames(n: int) -> np.ndarray:
    """Compressible frames (gradients, like rendered images), different per frame."""
    y, x = np.mgrid[0:H, 0:W]
    return np.stack(
        [np.stack([(x * 8 + t) % 256, (y * 10) % 256, np.full_like(x, t)], -1) for t in range(n)]
    ).astype(np.uint8)


@pytest.mark.parametrize("workers, max_pending", [(1, 1), (2, None), (3, 2)])
def test_frames_round_trip_through_plain_h5py(tmp_path, workers, max_pending):
    frames = _smooth_frames(12)
    path = tmp_path / "a.hdf5"
    with h5py.File(path, "w") as f:
        ds = _dataset(f, 12)
        comp = ChunkCompressor(1, workers=workers, max_pending=max_pending)
        for t, frame in enumerate(frames):
            comp.submit(ds, t, frame)
            frame[...] = 0  # the caller may reuse its buffer at once
        comp.close()
    with h5py.File(path, "r") as f:  # the standard deflate filter decodes them
        ds = f["img"]
        assert ds.compression == "gzip" and ds.compression_opts == 1
        np.testing.assert_array_equal(ds[()], _smooth_frames(12))
        for t in range(12):
            mask, raw = ds.id.read_direct_chunk((t, 0, 0, 0))
            assert mask == 0 and len(raw) < H * W * 3  # stored compressed
            assert zlib.decompress(raw) == _smooth_frames(12)[t].tobytes()


def test_incompressible_frames_are_stored_raw_and_still_read(tmp_path):
    frames = np.random.default_rng(0).integers(0, 256, (3, H, W, 3), dtype=np.uint8)
    path = tmp_path / "a.hdf5"
    with h5py.File(path, "w") as f:
        ds = _dataset(f, 3, level=9)
        comp = ChunkCompressor(9)
        for t, frame in enumerate(frames):
            comp.submit(ds, t, frame)
        comp.close()
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(f["img"][()], frames)
        mask, raw = f["img"].id.read_direct_chunk((1, 0, 0, 0))
        assert mask == 1 and raw == frames[1].tobytes()  # deflate skipped for this chunk


def test_cancel_writes_nothing_more(tmp_path, monkeypatch):
    # the one compression thread is held until cancel has been asked for, so no frame is
    # finished while they are submitted and none may be written after cancel (no race: the
    # writes happen on the caller's thread, only for finished frames)
    gate = threading.Event()
    compress = chunk_compressor._compress

    def held(*args, **kwargs):
        gate.wait(10)
        return compress(*args, **kwargs)

    monkeypatch.setattr(chunk_compressor, "_compress", held)
    with h5py.File(tmp_path / "a.hdf5", "w") as f:
        ds = _dataset(f, 50)
        comp = ChunkCompressor(1, workers=1, max_pending=100)
        for t, frame in enumerate(_smooth_frames(50)):
            comp.submit(ds, t, frame)
        threading.Timer(0.3, gate.set).start()  # cancel waits for the running frame, then
        comp.cancel()
        comp.cancel()  # idempotent
        written = ds.id.get_num_chunks()
    assert written == 0


def test_write_failure_surfaces_on_the_caller_thread(tmp_path, monkeypatch):
    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(chunk_compressor, "write_chunk", full)
    with h5py.File(tmp_path / "a.hdf5", "w") as f:
        ds = _dataset(f, 4)
        comp = ChunkCompressor(1, workers=1)
        with pytest.raises(OSError) as exc_info:
            for t, frame in enumerate(_smooth_frames(4)):
                comp.submit(ds, t, frame)
            comp.flush()
        comp.cancel()
    assert exc_info.value.errno == errno.ENOSPC


@pytest.mark.parametrize("level", [0, 10])
def test_level_must_be_1_to_9(level):
    with pytest.raises(ValueError, match="1..9"):
        ChunkCompressor(level)


def test_level_1_uses_isal_with_zlib_streams_of_zlib_level_1_size():
    pytest.importorskip("isal", reason="isal is a dependency: pip install isal")
    from isal import isal_zlib

    assert chunk_compressor.deflate_function(1) is isal_zlib.compress
    assert chunk_compressor.deflate_function(6) is zlib.compress
    y, x = np.mgrid[0:96, 0:128]
    scene = np.stack([(x // 8 * 30) % 256, (y // 6 * 20) % 256, (x + y) % 7 * 30], -1)
    frame = scene.astype(np.uint8)
    data, mask = chunk_compressor._compress(frame, 1)
    assert mask == 0 and zlib.decompress(data) == frame.tobytes()  # a zlib stream
    assert len(data) <= 1.1 * len(zlib.compress(frame, 1))  # no bigger than zlib's level 1
