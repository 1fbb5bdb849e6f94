"""Fixtures of the export tests: episodes from the real recorder, and written directly."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli

CAMS = ["cam_high", "cam_left_wrist"]
H, W = 48, 64
STEPS = 20


@pytest.fixture(scope="session")
def recorded(tmp_path_factory) -> Path:
    """2 recorded transfer-cube episodes: 20 steps, 2 cameras 48x64, gzip images."""
    root = tmp_path_factory.mktemp("recorded")
    rc = record_cli(
        [
            "--data_dir",
            "eps",
            "--root_dir",
            str(root),
            "--num_episodes",
            "2",
            "--episode_len",
            str(STEPS),
            "--cam_names",
            ",".join(CAMS),
            "--image_size",
            f"{H}x{W}",
            "--compression",
            "gzip",
        ]
    )
    assert rc in (0, 1)  # 20 steps are too few for the scripted policy: record exits 1
    return root / "eps"


def write_episode(
    path: Path,
    steps: int,
    cams: list[str],
    seed: int,
    size: tuple[int, int] = (H, W),
    compression: str = "none",
    task_name: str = "sim_insertion",
) -> None:
    """A valid episode: images with a moving square (each step differs clearly from the
    others), random joint values, rewards 0..4 (successes from step 8)."""
    rng = np.random.default_rng(seed)
    h, w = size
    yy, xx = np.mgrid[0:h, 0:w]
    with EpisodeWriter(
        path,
        steps,
        cams,
        h,
        w,
        compression=compression,
        env_state_dim=14,
        attrs={"task_name": task_name, "seed": seed},
    ) as writer:
        for t in range(steps):
            images = {}
            for c, cam in enumerate(cams):  # a gradient, and a red square moving 3 px a step
                base = 40 + (150 * (xx + yy) // (h + w)).astype(np.uint8)
                image = np.stack([base, base, 255 - base], -1).astype(np.uint8)
                x0, y0 = (3 * t + 7 * c) % max(1, w - 12), h // 3
                image[y0 : y0 + 12, x0 : x0 + 12] = (230, 30, 30)
                images[cam] = image
            writer.append(
                rng.normal(size=16),
                rng.normal(size=16),
                rng.normal(size=16),
                float(min(4, t // 2)),
                rng.normal(size=14),
                images,
            )
        writer.set_attrs(success=True)


def to_float32(path: Path) -> None:
    """Rewrite the numeric datasets of an episode file as float32 (the newer writer's)."""
    with h5py.File(path, "r+") as f:
        for name in ("action", "reward", "observations/qpos", "observations/qvel"):
            data = f[name][()].astype(np.float32)
            del f[name]
            f.create_dataset(name, data=data)


@pytest.fixture(scope="session")
def make_episode():
    """Factory: ``make_episode(path, steps, cams, seed, size=(48, 64), compression="none")``."""
    return write_episode


@pytest.fixture(scope="session")
def make_float32():
    """``make_float32(path)`` rewrites an episode's numeric datasets as float32."""
    return to_float32
