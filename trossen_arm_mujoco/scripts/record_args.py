"""The record command's arguments.

``build_parser`` declares the flags (those other commands share through
``scripts.common_options``); ``record_options`` checks them together (task name and
aliases, counts and seed within their bounds, cameras, image size, scene looks, workers and
engine) and turns them into the run's ``RecordSettings``; unset flags come from
``SIM_TASK_CONFIGS[task_name]``. Every mistake is a one-line ``UserError`` naming the flag.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.schema import GZIP_LEVEL
from trossen_arm_mujoco.errors import ArgumentParser, UserError
from trossen_arm_mujoco.processes import available_cpus
from trossen_arm_mujoco.scripts.common_options import (
    MAX_EPISODE_LEN,
    MAX_EPISODES,
    add_cameras,
    add_compression,
    add_crop,
    add_data_dir,
    add_engine,
    add_episode_len,
    add_image_size,
    add_looks,
    add_num_episodes,
    add_overwrite,
    add_root_dir,
    add_seed,
    add_task_name,
    add_wait,
    camera_names,
    check_seed,
    image_size,
    scene_looks,
)
from trossen_arm_mujoco.sim.camera_crop import check_observed

__all__ = [
    "RecordOptions",
    "build_parser",
    "check_numbers",
    "num_workers",
    "record_options",
]

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.pipeline import RecordSettings


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``trossen-mujoco record``."""
    p = ArgumentParser(
        prog="trossen-mujoco record",
        description="Record scripted simulation episodes (two-phase: mocap rollout, joint "
        "replay with cameras) into HDF5 files.",
    )
    add_task_name(p, "task to record")
    add_data_dir(p)
    add_root_dir(p)
    add_num_episodes(p, "episodes the dataset should hold", None, "task config")
    add_episode_len(p, f"steps per episode at 50 Hz, at most {MAX_EPISODE_LEN}", "task config, 600")
    p.add_argument(
        "--onscreen_render",
        action="store_true",
        default=None,
        help="show a live viewer with the camera images while recording",
    )
    p.add_argument(
        "--inject_noise",
        action="store_true",
        default=None,
        help="perturb the scripted waypoints (seeded)",
    )
    p.add_argument(
        "--randomize",
        action="store_true",
        help="domain randomization (lights, table and object colours and textures, friction, "
        "masses, damping, cameras, joint noise) as the task YAML's 'randomization' section "
        "says; each episode stores it in its 'randomization' attribute (default: off)",
    )
    add_cameras(p, "cameras to record", "all 4")
    add_seed(p, "run seed, 0 .. 2**63-1; episode k uses a seed derived from (seed, k)")
    p.add_argument(
        "--num_workers",
        type=int,
        default=None,
        help="episodes recorded at once: local worker processes (default: 1; at most the "
        "CPUs, a worker that dies is replaced and its episode retried), or with --engine ray "
        "the Ray tasks in flight (default: the cluster's CPUs; also the CPUs of a local "
        "Ray); results are identical for any number",
    )
    add_engine(p, "where episodes run: local processes, or one Ray task each")
    p.add_argument(
        "--ray_address",
        default=None,
        help="with --engine ray: 'auto', HOST:PORT or ray://HOST:PORT of a running Ray "
        "cluster (default: start a local Ray on this machine)",
    )
    add_overwrite(p, "start afresh at episode 0, replacing existing episodes")
    p.add_argument(
        "--skip_failed",
        action="store_true",
        help="keep attempting until num_episodes successful episodes are saved (without it "
        "failed episodes are kept, the exit status is 1, and a rerun records them again)",
    )
    add_wait(
        p,
        "when another record run is writing to the folder, wait for it to finish and "
        "then continue the dataset (default: refuse, naming its pid)",
    )
    add_compression(
        p, f", level {GZIP_LEVEL}, compressed off the render path; 'none' for raw frames"
    )
    add_image_size(p)
    add_looks(p)
    add_crop(p)
    return p


def num_workers(args: argparse.Namespace) -> int | None:
    """``--num_workers``, at most the CPUs of this machine (with a warning) unless the
    episodes run on a Ray cluster elsewhere."""
    n = args.num_workers
    if n is None or (args.engine == "ray" and args.ray_address is not None):
        return n
    most = available_cpus()
    if n > most:
        print(
            f"warning: --num_workers {n} is more than the {most} CPUs of this machine; "
            f"using {most}",
            file=sys.stderr,
        )
        return most
    return n


def check_numbers(args: argparse.Namespace, num_episodes: int, episode_len: int) -> None:
    """Counts, length, seed and workers within their bounds (one-line UserErrors).

    Args:
        args: the parsed flags (``--seed``, ``--num_workers``).
        num_episodes: the resolved episode count.
        episode_len: the resolved episode length (steps).
    """
    if not 1 <= num_episodes <= MAX_EPISODES:
        raise UserError(f"--num_episodes must be in 1 .. {MAX_EPISODES}, got {num_episodes}")
    if not 1 <= episode_len <= MAX_EPISODE_LEN:
        raise UserError(
            f"--episode_len must be in 1 .. {MAX_EPISODE_LEN} steps (2000 s at 50 Hz), "
            f"got {episode_len}"
        )
    check_seed(args.seed)
    if args.num_workers is not None and args.num_workers < 1:
        raise UserError(f"--num_workers must be at least 1, got {args.num_workers}")


@dataclass(frozen=True)
class RecordOptions:
    """A record run's checked options.

    Attributes:
        settings: what every episode is recorded with.
        num_episodes: episodes the dataset should hold.
        onscreen: show a live viewer while recording.
    """

    settings: RecordSettings
    num_episodes: int
    onscreen: bool


def record_options(args: argparse.Namespace) -> RecordOptions:
    """The parsed flags checked together; ``args.task_name`` becomes the registered name
    (aliases accepted) and ``args.num_workers`` is capped at the CPUs (with a warning)."""
    from trossen_arm_mujoco.tasks.registry import canonical

    args.task_name = canonical(args.task_name)  # an alias, an installed package's task
    if args.task_name not in SIM_TASK_CONFIGS:
        raise UserError(
            f"task '{args.task_name}' has no scripted policy to record; tasks with one: "
            f"{', '.join(sorted(SIM_TASK_CONFIGS))}"
        )
    config = SIM_TASK_CONFIGS[args.task_name]
    num_episodes = config["num_episodes"] if args.num_episodes is None else args.num_episodes
    episode_len = config["episode_len"] if args.episode_len is None else args.episode_len
    onscreen = config["onscreen_render"] if args.onscreen_render is None else True
    noise = config["inject_noise"] if args.inject_noise is None else True
    check_numbers(args, num_episodes, episode_len)
    if args.ray_address is not None and args.engine != "ray":
        raise UserError("--ray_address needs --engine ray")
    if onscreen and (args.engine != "local" or (args.num_workers or 1) != 1):
        raise UserError("--onscreen_render needs --engine local and --num_workers 1")
    if args.engine == "ray":
        from trossen_arm_mujoco.collect.ray_session import import_ray

        import_ray()  # fail now, with the install hint, when Ray is missing
    cams = camera_names(args.cam_names, args.task_name)
    height, width = image_size(args.image_size)
    looks = scene_looks(args)
    for crop in looks.crops:  # a camera of the task's scene, checked before any episode
        camera_names(crop.camera, args.task_name)
    check_observed(looks.crops, cams, "recorded")
    args.num_workers = num_workers(args)

    from trossen_arm_mujoco.collect.pipeline import RecordSettings

    settings = RecordSettings(
        task_name=args.task_name,
        episode_len=episode_len,
        inject_noise=noise,
        cam_names=cams,
        height=height,
        width=width,
        compression=args.compression,
        base_seed=args.seed,
        randomize=args.randomize,
        shadows=looks.shadows,
        antialias=looks.antialias,
        visual=looks.visual,
        crops=looks.crops,  # parsed once, here
    )
    return RecordOptions(settings, num_episodes, onscreen)
