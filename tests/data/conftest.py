"""Fixtures of the data tests: tiny episodes written with the real writer."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trossen_arm_mujoco.data.writer import EpisodeWriter

FIXTURES = Path(__file__).parents[1] / "fixtures"
VENDOR_4CAMS = FIXTURES / "vendor_episode_5steps_4cams.hdf5"
VENDOR_NO_IMAGES = FIXTURES / "vendor_transfer_cube_600steps_noimages.hdf5"

CAMS = ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]
H, W = 24, 32
BOX_POSE = [0.01, -0.15, 0.0125, 1.0, 0.0, 0.0, 0.0]


def episode_data(
    num_steps: int, cams: list[str], height: int = H, width: int = W, seed: int = 0
) -> dict[str, Any]:
    """Random but valid per-episode arrays: qpos etc. (T, 16), images {cam: (T, H, W, 3)}."""
    rng = np.random.default_rng(seed)
    return {
        "qpos": rng.normal(size=(num_steps, 16)),
        "qvel": rng.normal(size=(num_steps, 16)),
        "action": rng.normal(size=(num_steps, 16)),
        "reward": rng.integers(0, 5, size=num_steps).astype(np.float64),
        "env_state": rng.normal(size=(num_steps, 7)),
        "images": {
            cam: rng.integers(0, 256, size=(num_steps, height, width, 3), dtype=np.uint8)
            for cam in cams
        },
    }


def write_episode(
    path: Path,
    num_steps: int = 4,
    cams: list[str] | None = None,
    height: int = H,
    width: int = W,
    compression: str = "none",
    seed: int = 0,
    **writer_kwargs: Any,
) -> dict[str, Any]:
    """Write a complete tiny episode to ``path``; returns the data written."""
    cams = list(CAMS if cams is None else cams)
    data = episode_data(num_steps, cams, height, width, seed)
    attrs = {"task_name": "sim_transfer_cube", "seed": seed, "box_pose": BOX_POSE}
    with EpisodeWriter(
        path,
        num_steps,
        cams,
        height,
        width,
        compression=compression,
        attrs=attrs,
        **writer_kwargs,
    ) as writer:
        for t in range(num_steps):
            writer.append(
                data["qpos"][t],
                data["qvel"][t],
                data["action"][t],
                data["reward"][t],
                data["env_state"][t],
                {cam: data["images"][cam][t] for cam in cams},
            )
        writer.set_attrs(success=True)
    return data


@pytest.fixture
def vendor_4cams() -> Path:
    """Vendor recording: 5 steps, 4 cameras 480x640, float32 arrays, no attributes."""
    return VENDOR_4CAMS


@pytest.fixture
def vendor_no_images() -> Path:
    """Vendor recording: 600 steps, no images (box pose in the .json next to it)."""
    return VENDOR_NO_IMAGES


@pytest.fixture
def make_episode() -> Callable[..., dict[str, Any]]:
    """Factory: ``make_episode(path, num_steps=4, cams=None, ...)`` (see write_episode)."""
    return write_episode
