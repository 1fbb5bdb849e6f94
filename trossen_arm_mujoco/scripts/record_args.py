"""The record command's arguments, and the recording options the serve and teleop commands
share with it.

``build_parser`` declares the flags; ``record_options`` checks them together (task name and
aliases, counts and seed within their bounds, cameras, image size, scene looks, workers and
engine) and turns them into the run's ``RecordSettings``; unset flags come from
``SIM_TASK_CONFIGS[task_name]``. ``camera_names``, ``image_size`` and ``dataset_folder`` are
the checks of ``--cam_names``, ``--image_size`` and ``--root_dir``/``--data_dir`` (a folder
this process can write in, checked before any work) every recording command makes. Every
mistake is a one-line ``UserError`` naming the flag.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from trossen_arm_mujoco.constants import ROOT_DIR, SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.schema import COMPRESSIONS, DEFAULT_COMPRESSION, GZIP_LEVEL
from trossen_arm_mujoco.errors import (
    ArgumentParser,
    UserError,
    describe_os_error,
    os_error_hint,
    unknown_name_error,
)

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.pipeline import RecordSettings
    from trossen_arm_mujoco.sim.looks import SceneLooks

#: Longest episode accepted (steps; 2000 s at 50 Hz).
MAX_EPISODE_LEN = 100_000
#: Most episodes one dataset may be asked to hold.
MAX_EPISODES = 1_000_000
#: Largest run seed (stored as a signed 64-bit attribute).
MAX_SEED = 2**63 - 1


def build_parser() -> argparse.ArgumentParser:
    p = ArgumentParser(
        prog="trossen-mujoco record",
        description="Record scripted simulation episodes (two-phase: mocap rollout, joint "
        "replay with cameras) into HDF5 files.",
    )
    p.add_argument(
        "--task_name",
        default="sim_transfer_cube",
        help="task to record (default: sim_transfer_cube)",
    )
    p.add_argument(
        "--data_dir", required=True, help="dataset folder, relative to --root_dir unless absolute"
    )
    p.add_argument("--root_dir", default=ROOT_DIR, help=f"root of datasets (default: {ROOT_DIR})")
    p.add_argument(
        "--num_episodes",
        type=int,
        default=None,
        help="episodes the dataset should hold (default: task config)",
    )
    p.add_argument(
        "--episode_len",
        type=int,
        default=None,
        help=f"steps per episode at 50 Hz, at most {MAX_EPISODE_LEN} (default: task config, 600)",
    )
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
    p.add_argument(
        "--cam_names",
        default=None,
        help="comma-separated cameras to record, or 'none' (default: all 4)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="run seed, 0 .. 2**63-1; episode k uses a seed derived from (seed, k) (default: 0)",
    )
    p.add_argument(
        "--num_workers",
        type=int,
        default=None,
        help="episodes recorded at once: local worker processes (default: 1; at most the "
        "CPUs, a worker that dies is replaced and its episode retried), or with --engine ray "
        "the Ray tasks in flight (default: the cluster's CPUs; also the CPUs of a local "
        "Ray); results are identical for any number",
    )
    p.add_argument(
        "--engine",
        default="local",
        choices=("local", "ray"),
        help="where episodes run: local processes, or one Ray task each (default: local)",
    )
    p.add_argument(
        "--ray_address",
        default=None,
        help="with --engine ray: 'auto', HOST:PORT or ray://HOST:PORT of a running Ray "
        "cluster (default: start a local Ray on this machine)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="start afresh at episode 0, replacing existing episodes",
    )
    p.add_argument(
        "--skip_failed",
        action="store_true",
        help="keep attempting until num_episodes successful episodes are saved (without it "
        "failed episodes are kept, the exit status is 1, and a rerun records them again)",
    )
    p.add_argument(
        "--wait",
        action="store_true",
        help="when another record run is writing to the folder, wait for it to finish and "
        "then continue the dataset (default: refuse, naming its pid)",
    )
    p.add_argument(
        "--compression",
        default=DEFAULT_COMPRESSION,
        choices=COMPRESSIONS,
        help=f"image compression (default: {DEFAULT_COMPRESSION}, level {GZIP_LEVEL}, "
        "compressed off the render path; 'none' for raw frames)",
    )
    p.add_argument(
        "--image_size", default="480x640", help="camera image size HEIGHTxWIDTH (default: 480x640)"
    )
    p.add_argument(
        "--no_shadows",
        action="store_true",
        help="render without shadows (faster with software rendering)",
    )
    p.add_argument(
        "--visual",
        default="own",
        help="arm meshes: 'own' (default) or 'menagerie' (the official Trossen meshes of the "
        "MuJoCo Menagerie checkout named by TROSSEN_MENAGERIE_DIR)",
    )
    return p


def image_size(text: str) -> tuple[int, int]:
    """``--image_size`` HEIGHTxWIDTH as (height, width) pixels, within 1x1 .. 480x640."""
    try:
        h, w = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UserError(f"--image_size must look like 480x640, got '{text}'") from None
    if not (0 < h <= 480 and 0 < w <= 640):
        raise UserError(f"--image_size must be within 1x1 .. 480x640, got {h}x{w}")
    return h, w


def camera_names(text: str | None, task_name: str) -> tuple[str, ...]:
    """``--cam_names`` (comma-separated, 'none', or None for the task's defaults) as camera
    names of the task, each once."""
    defaults = SIM_TASK_CONFIGS[task_name]["cam_names"]
    if text is None:
        return tuple(defaults)
    if text.strip().lower() == "none":
        return ()
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise UserError("--cam_names is empty; give camera names or 'none'")
    for name in names:
        if name not in defaults:
            raise unknown_name_error("camera", name, defaults, "or 'none' for no images")
    if len(set(names)) != len(names):
        raise UserError(f"--cam_names lists a camera twice: {names}")
    return tuple(names)


def scene_looks(args: argparse.Namespace) -> SceneLooks:
    """The scene looks of --no_shadows / --visual, checked now (before any episode)."""
    from trossen_arm_mujoco.sim.looks import SceneLooks, menagerie_meshes

    looks = SceneLooks(shadows=not args.no_shadows, visual=args.visual)
    if looks.visual == "menagerie":
        menagerie_meshes()  # fail now with the fix, not in a worker
    return looks


def dataset_folder(
    root: str, data_dir: str, flag: str = "--data_dir", *, create: bool = True
) -> Path:
    """The dataset folder ``data_dir`` (relative to ``root`` unless absolute), checked and
    created (unless ``create`` is False: then nothing is left behind) before any work.

    A file, a symlink loop or a link to a missing path on the way (naming ``--root_dir``
    when it lies in the root, else ``flag``, the flag that gave ``data_dir``), or a folder
    the file system will not let this process write in
    (:func:`~trossen_arm_mujoco.fileio.check_writable_dir`), is a one-line UserError."""
    from trossen_arm_mujoco.data.reader import resolve_data_dir
    from trossen_arm_mujoco.fileio import check_folder_path, check_writable_dir

    folder = resolve_data_dir(root, data_dir)
    if not Path(data_dir).expanduser().is_absolute():
        check_folder_path(root, "--root_dir")
    check_writable_dir(folder, flag)
    if not create:
        return folder
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # changed since the check
        raise UserError(
            f"cannot write to {flag} {folder}: {describe_os_error(exc)}; {os_error_hint(exc, flag)}"
        ) from None
    return folder


def cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def num_workers(args: argparse.Namespace) -> int | None:
    """``--num_workers``, at most the CPUs of this machine (with a warning) unless the
    episodes run on a Ray cluster elsewhere."""
    n = args.num_workers
    if n is None or (args.engine == "ray" and args.ray_address is not None):
        return n
    most = cpus()
    if n > most:
        print(
            f"warning: --num_workers {n} is more than the {most} CPUs of this machine; "
            f"using {most}",
            file=sys.stderr,
        )
        return most
    return n


def check_numbers(args: argparse.Namespace, num_episodes: int, episode_len: int) -> None:
    """Counts, length, seed and workers within their bounds."""
    if not 1 <= num_episodes <= MAX_EPISODES:
        raise UserError(f"--num_episodes must be in 1 .. {MAX_EPISODES}, got {num_episodes}")
    if not 1 <= episode_len <= MAX_EPISODE_LEN:
        raise UserError(
            f"--episode_len must be in 1 .. {MAX_EPISODE_LEN} steps (2000 s at 50 Hz), "
            f"got {episode_len}"
        )
    if not 0 <= args.seed <= MAX_SEED:
        raise UserError(f"--seed must be in 0 .. 2**63-1 ({MAX_SEED}), got {args.seed}")
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
    from trossen_arm_mujoco.tasks.registry import ALIASES

    args.task_name = ALIASES.get(args.task_name, args.task_name)  # a registered alias
    if args.task_name not in SIM_TASK_CONFIGS:
        raise unknown_name_error("task", args.task_name, SIM_TASK_CONFIGS)
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
        visual=looks.visual,
    )
    return RecordOptions(settings, num_episodes, onscreen)
