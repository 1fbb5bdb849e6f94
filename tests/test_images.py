"""PNG writing through Pillow, atomically."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from trossen_arm_mujoco import images
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.images import encode_png, write_png


def _random_image(h: int = 7, w: int = 5) -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, size=(h, w, 3), dtype=np.uint8)


def test_encode_png_round_trip():
    img = _random_image()
    data = encode_png(img)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(io.BytesIO(data)) as decoded:
        assert decoded.mode == "RGB" and decoded.size == (5, 7)
        np.testing.assert_array_equal(np.asarray(decoded), img)


def test_write_png_round_trip_and_replace(tmp_path):
    path = tmp_path / "cam.png"
    path.write_bytes(b"old")
    img = _random_image(4, 6)
    assert write_png(path, img) == path
    with Image.open(path) as decoded:
        np.testing.assert_array_equal(np.asarray(decoded), img)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cam.png"]


def test_non_contiguous_views_are_written_as_shown(tmp_path):
    img = _random_image(8, 10)[::2, ::-1]
    write_png(tmp_path / "v.png", img)
    with Image.open(tmp_path / "v.png") as decoded:
        np.testing.assert_array_equal(np.asarray(decoded), img)


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((4, 4), np.uint8), "RGB"),
        (np.zeros((4, 4, 4), np.uint8), "RGB"),
        (np.zeros((4, 4, 3), np.float32), "uint8"),
    ],
)
def test_rejects_anything_but_rgb_uint8(tmp_path, image, message):
    with pytest.raises(UserError, match=message):
        write_png(tmp_path / "x.png", image)
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "cam.png"
    path.write_bytes(b"old")

    def failing_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr("trossen_arm_mujoco.fileio.os.replace", failing_replace)
    with pytest.raises(OSError, match="disk full"):
        images.write_png(path, _random_image())
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cam.png"]


def test_psnr_of_identical_and_of_different_images():
    from trossen_arm_mujoco.images import psnr

    a = np.zeros((4, 5, 3), np.uint8)
    assert psnr(a, a) == float("inf")
    b = a.copy()
    b[0, 0, 0] = 255  # one channel of one pixel off by the full scale: mse = 255**2 / 60
    assert psnr(a, b) == pytest.approx(10 * np.log10(60))
