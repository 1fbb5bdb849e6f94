"""Camera images: PNG files (encoded by Pillow, written atomically) and how close two are
(PSNR).

Docs: docs/testing.md.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import write_bytes

__all__ = ["encode_png", "psnr", "write_png"]


def _rgb(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3:
        raise UserError(f"expected an RGB image (H, W, 3), got shape {img.shape}")
    if img.dtype != np.uint8:
        raise UserError(f"expected a uint8 image (0..255), got dtype {img.dtype}")
    return np.ascontiguousarray(img)


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an RGB uint8 ``(H, W, 3)`` image."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(_rgb(image)).save(buf, format="PNG")
    return buf.getvalue()


def write_png(path: str | os.PathLike[str], image: np.ndarray) -> Path:
    """Write an RGB uint8 ``(H, W, 3)`` image as a PNG file (replaced if it exists; never
    seen half-written). The folder must exist. Returns ``path``."""
    return write_bytes(path, encode_png(image))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """Peak signal-to-noise ratio (dB) of two uint8 images of one shape, on the 0..255 scale;
    ``inf`` for identical images."""
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else float(10.0 * np.log10(255.0**2 / mse))
