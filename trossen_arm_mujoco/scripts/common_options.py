"""The command-line options that several commands share, declared once.

``record``, ``teleop``, ``serve``, ``export`` and ``eval`` share flags: the task, where
datasets live, the run seed, cameras and image size, the rate, episode counts and lengths,
compression, the scene's looks, the engine, a viewer, ``--wait`` and ``--overwrite``. Each
``add_*`` function declares one (type, default, help ending in ``(default: ...)``); the
checks (``check_seed``, ``camera_names``, ``image_size``, ``dataset_folder``,
``scene_looks``) turn parsed text into values, every mistake a one-line ``UserError`` naming
the flag::

    >>> p = ArgumentParser(prog="trossen-mujoco record")
    >>> add_task_name(p, "task to record")

Docs: docs/cli/index.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trossen_arm_mujoco.constants import ROOT_DIR, SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.schema import COMPRESSIONS, DEFAULT_COMPRESSION
from trossen_arm_mujoco.errors import (
    UserError,
    describe_os_error,
    os_error_hint,
    unknown_name_error,
)
from trossen_arm_mujoco.tasks import registry

if TYPE_CHECKING:
    from trossen_arm_mujoco.sim.looks import SceneLooks

__all__ = [
    "DEFAULT_IMAGE_SIZE",
    "DEFAULT_TASK",
    "ENGINES",
    "MAX_EPISODES",
    "MAX_EPISODE_LEN",
    "MAX_RECORD_IMAGE_SIZE",
    "MAX_SEED",
    "randomization_of",
    "add_cameras",
    "add_compression",
    "add_crop",
    "add_randomize",
    "add_data_dir",
    "add_engine",
    "add_episode_len",
    "add_fps",
    "add_image_size",
    "add_looks",
    "add_num_episodes",
    "add_overwrite",
    "add_root_dir",
    "add_seed",
    "add_task_name",
    "add_viewer",
    "add_wait",
    "camera_names",
    "check_seed",
    "dataset_folder",
    "image_size",
    "scene_looks",
]

#: The task every command starts from when ``--task_name`` is not given.
DEFAULT_TASK = registry.DEFAULT_TASK
#: Camera image size of the recording commands, HEIGHTxWIDTH pixels (also the largest:
#: MAX_RECORD_IMAGE_SIZE, height and width).
DEFAULT_IMAGE_SIZE = "480x640"
MAX_RECORD_IMAGE_SIZE = (480, 640)
#: Largest run seed (stored as a signed 64-bit attribute).
MAX_SEED = 2**63 - 1
#: Longest episode accepted (steps; 2000 s at 50 Hz).
MAX_EPISODE_LEN = 100_000
#: Most episodes one dataset may be asked to hold.
MAX_EPISODES = 1_000_000
#: Where episodes run: local worker processes, or Ray tasks.
ENGINES = ("local", "ray")

_Parser = argparse.ArgumentParser  # in the signatures below


# -- declarations ------------------------------------------------------------------------
def add_task_name(p: _Parser, what: str) -> None:
    """``--task_name``: a registered task (aliases accepted), default ``sim_transfer_cube``;
    ``what`` says what the task is for in this command."""
    p.add_argument("--task_name", default=DEFAULT_TASK, help=f"{what} (default: {DEFAULT_TASK})")


def add_root_dir(p: _Parser) -> None:
    """``--root_dir``: the folder dataset folders are relative to (default ``ROOT_DIR``,
    ``~/.trossen/mujoco/data/``)."""
    p.add_argument("--root_dir", default=ROOT_DIR, help=f"root of datasets (default: {ROOT_DIR})")


def add_data_dir(p: _Parser, what: str = "dataset folder", example: str = "") -> None:
    """``--data_dir`` (required), relative to ``--root_dir`` unless absolute.

    Args:
        p: the parser (or argument group).
        what: what the folder is, for the help.
        example: appended to the help as ``(e.g. ...)``.
    """
    tail = f" (e.g. {example})" if example else ""
    p.add_argument(
        "--data_dir", required=True, help=f"{what}, relative to --root_dir unless absolute{tail}"
    )


def add_seed(p: _Parser, what: str) -> None:
    """``--seed``: an int, default 0 (``check_seed`` bounds it); ``what`` says how the
    command derives its episodes from it."""
    p.add_argument("--seed", type=int, default=0, help=f"{what} (default: 0)")


def add_cameras(p: _Parser, what: str, default: str) -> None:
    """``--cam_names``: comma-separated camera names or ``none``; None when not given.

    Args:
        p: the parser (or argument group).
        what: which cameras, for the help (e.g. "cameras to record").
        default: what the command uses when the flag is not given, for the help.
    """
    p.add_argument(
        "--cam_names", default=None, help=f"comma-separated {what}, or 'none' (default: {default})"
    )


def add_image_size(
    p: _Parser,
    what: str = "camera image size",
    default: str | None = DEFAULT_IMAGE_SIZE,
    default_text: str | None = None,
) -> None:
    """``--image_size`` HEIGHTxWIDTH (pixels).

    Args:
        p: the parser (or argument group).
        what: what the size is of, for the help.
        default: the default text (``HxW``), or None (not given).
        default_text: describes a None default, for the help.
    """
    shown = default if default_text is None else default_text
    p.add_argument("--image_size", default=default, help=f"{what} HEIGHTxWIDTH (default: {shown})")


def add_fps(p: _Parser, what: str, default: str) -> None:
    """``--fps``: a rate in Hz (float, None when not given).

    Args:
        p: the parser (or argument group).
        what: what the rate is, for the help.
        default: what the command uses when the flag is not given, for the help.
    """
    p.add_argument("--fps", type=float, default=None, help=f"{what} (default: {default})")


def add_num_episodes(p: _Parser, what: str, default: int | None, default_text: str = "") -> None:
    """``--num_episodes``: an int.

    Args:
        p: the parser (or argument group).
        what: what the count is, for the help.
        default: the default (None: not given).
        default_text: describes a None default, for the help.
    """
    shown = default_text or str(default)
    p.add_argument("--num_episodes", type=int, default=default, help=f"{what} (default: {shown})")


def add_episode_len(p: _Parser, what: str, default: str) -> None:
    """``--episode_len``: steps per episode (int, None when not given).

    Args:
        p: the parser (or argument group).
        what: what the length is, for the help.
        default: what the command uses when the flag is not given, for the help.
    """
    p.add_argument("--episode_len", type=int, default=None, help=f"{what} (default: {default})")


def add_engine(p: _Parser, what: str) -> None:
    """``--engine``: ``local`` (default) or ``ray``."""
    p.add_argument("--engine", default="local", choices=ENGINES, help=f"{what} (default: local)")


def add_compression(p: _Parser, detail: str = "") -> None:
    """``--compression``: image compression of the episode files (``data.schema``)."""
    p.add_argument(
        "--compression",
        default=DEFAULT_COMPRESSION,
        choices=COMPRESSIONS,
        help=f"image compression (default: {DEFAULT_COMPRESSION}{detail})",
    )


def add_looks(p: _Parser, visual: bool = True) -> None:
    """``--no_shadows``, ``--no_antialias`` and (``visual``) ``--visual``: how the scene is
    drawn (``sim.looks.SceneLooks``; ``scene_looks`` checks them)."""
    p.add_argument(
        "--no_shadows",
        action="store_true",
        help="render without shadows (faster with software rendering)",
    )
    p.add_argument(
        "--no_antialias",
        action="store_true",
        help="render one sample a pixel, without smoothing edges (about half the CPU of a "
        "frame with software rendering)",
    )
    if visual:
        p.add_argument(
            "--visual",
            default="own",
            help="arm meshes: 'own' (default) or 'menagerie' (the official Trossen meshes of "
            "the MuJoCo Menagerie checkout named by TROSSEN_MENAGERIE_DIR)",
        )


def add_randomize(p: _Parser, where: str) -> None:
    """``--randomize`` and ``--randomization FILE``: each episode's scene randomized
    (``randomization_of`` reads them); ``where``: where each episode's record goes."""
    from trossen_arm_mujoco.tasks.randomization_levels import LEVELS

    p.add_argument(
        "--randomize",
        nargs="?",
        const="train",
        default=None,
        choices=LEVELS,
        metavar="LEVEL",
        help="randomize each episode's scene from the episode's seed: 'train' (the "
        "flag alone: the task's randomization section: lights, table, colours, "
        "friction, masses, damping, camera poses, the arms' start), 'hard' (every "
        "range widened past training's) or 'nominal' (none, the default); the "
        f"record goes to {where}",
    )
    p.add_argument(
        "--randomization",
        default=None,
        metavar="FILE",
        help="YAML file of randomization kinds and ranges (its 'randomization' "
        "section, or kinds at the top level) replacing the task's, kind by kind; "
        "implies --randomize",
    )


def randomization_of(args: argparse.Namespace, task: str) -> tuple[bool, dict[str, Any] | None]:
    """``(randomize, section)`` of ``add_randomize``'s flags for ``task``: the level
    (``tasks.randomization_levels``) and the file read and checked (one-line UserErrors);
    section None: the task's own."""
    from trossen_arm_mujoco.tasks.config import read_randomization
    from trossen_arm_mujoco.tasks.randomization_levels import level_section

    path = args.randomization
    section = None if path is None else read_randomization(Path(path).expanduser())
    return level_section(args.randomize, task, section)


def add_crop(p: _Parser) -> None:
    """``--crop CAMERA:TOP,LEFT,HEIGHT,WIDTH`` (repeatable): a camera shows one rectangle of
    its 480x640 frame (``sim.camera_crop``; ``scene_looks`` checks it)."""
    p.add_argument(
        "--crop",
        action="append",
        default=None,
        metavar="CAMERA:TOP,LEFT,HEIGHT,WIDTH",
        help="the camera shows this rectangle of its 480x640 frame, drawn at --image_size "
        "(a crop of the workspace, e.g. cam_high:217,243,150,200 around the cube; "
        "repeat for more cameras; default: whole frames)",
    )


def add_viewer(p: _Parser, what: str = "show the simulation in a live viewer") -> None:
    """``--viewer``: a live MuJoCo viewer (needs a display)."""
    p.add_argument("--viewer", action="store_true", help=what)


def add_wait(p: _Parser, what: str) -> None:
    """``--wait``: wait for another run writing to the dataset folder instead of refusing."""
    p.add_argument("--wait", action="store_true", help=what)


def add_overwrite(p: _Parser, what: str) -> None:
    """``--overwrite``: replace what an earlier run left in the output."""
    p.add_argument("--overwrite", action="store_true", help=what)


# -- checks ------------------------------------------------------------------------------
def check_seed(seed: int, most: int = MAX_SEED) -> int:
    """``--seed`` within 0 .. ``most`` (default 2**63-1), else a UserError."""
    if not 0 <= seed <= most:
        shown = "2**63-1" if most == MAX_SEED else str(most)
        raise UserError(f"--seed must be in 0 .. {shown}, got {seed}")
    return seed


def image_size(text: str) -> tuple[int, int]:
    """``--image_size`` HEIGHTxWIDTH as (height, width) pixels, within 1x1 .. 480x640."""
    try:
        h, w = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UserError(f"--image_size must look like 480x640, got '{text}'") from None
    if not (0 < h <= MAX_RECORD_IMAGE_SIZE[0] and 0 < w <= MAX_RECORD_IMAGE_SIZE[1]):
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
    """The scene looks of ``--no_shadows`` / ``--no_antialias`` / ``--visual`` / ``--crop``
    (``own`` and no crop when the command lacks them), checked now (before any episode)."""
    from trossen_arm_mujoco.sim.camera_crop import parse_crops
    from trossen_arm_mujoco.sim.looks import SceneLooks, menagerie_meshes

    looks = SceneLooks(
        shadows=not args.no_shadows,
        antialias=not getattr(args, "no_antialias", False),
        visual=getattr(args, "visual", "own"),
        crops=parse_crops(getattr(args, "crop", None)),
    )
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
    (:func:`~trossen_arm_mujoco.fileio.check_writable_dir`), is a one-line UserError.

    Args:
        root: ``--root_dir``.
        data_dir: the folder, relative to ``root`` unless absolute.
        flag: the flag that gave ``data_dir``, for errors.
        create: create the folder (False: nothing is left behind).
    """
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
