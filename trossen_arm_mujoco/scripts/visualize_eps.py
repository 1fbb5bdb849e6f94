"""Turn recorded episodes into videos and joint plots (also ``trossen-mujoco visualize``).

For every ``episode_<k>.hdf5`` in the data folder: ``episode_<k>.mp4`` (all cameras in a
labelled grid, H.264) when the episode has images, and ``episode_<k>_joints.png`` (qpos
against action, one subplot per joint). Each file appears only once complete; Ctrl-C or
SIGTERM removes the file in progress (exit 130 or 143) and keeps the finished ones; the next
run removes the temporary files of a killed one. One run at a time writes into a folder, and
an output folder it cannot write in stops it with one line before any episode is read::

    python trossen_arm_mujoco/scripts/visualize_eps.py --data_dir sim_transfer_cube

Docs: docs/cli/visualize.md.
"""

from __future__ import annotations

__all__ = ["OWN_FILES", "build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from trossen_arm_mujoco.constants import ROOT_DIR
from trossen_arm_mujoco.data.reader import list_episodes, load_episode, resolve_data_dir
from trossen_arm_mujoco.data.video import h264_encoder, plot_joints, write_episode_video
from trossen_arm_mujoco.errors import (
    ArgumentParser,
    UserError,
    describe_os_error,
    interrupt_note,
    os_error_hint,
    run_cli,
)
from trossen_arm_mujoco.fileio import (
    FolderBusyError,
    check_writable_dir,
    folder_lock,
    remove_stale_temps,
)

#: Final names of the files this command writes (their temporary names are ``.<name>.tmp``).
OWN_FILES = r"episode_\d+(\.mp4|_joints\.png)"


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    parser = ArgumentParser(
        prog="trossen-mujoco visualize",
        description="Write an mp4 (camera grid) and a joint plot for each recorded episode.",
    )
    parser.add_argument(
        "--data_dir",
        required=True,
        help="dataset folder, relative to --root_dir unless absolute (e.g. sim_transfer_cube)",
    )
    parser.add_argument(
        "--root_dir", default=ROOT_DIR, help=f"root of the datasets (default {ROOT_DIR})"
    )
    parser.add_argument(
        "--output_dir",
        default="videos",
        help="where videos and plots go, inside the data folder unless absolute (default: videos)",
    )
    parser.add_argument(
        "--fps", type=float, default=50.0, help="video frame rate (default 50 = real time)"
    )
    parser.add_argument(
        "--episode_idx", type=int, default=None, help="only this episode (default: all)"
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Visualize the episodes of ``--data_dir``; returns the exit status."""
    args = build_parser().parse_args(argv)
    if not 0 < args.fps <= 1000:
        raise UserError(f"--fps must be in (0, 1000], got {args.fps:g}")
    data_dir = resolve_data_dir(args.root_dir, args.data_dir)
    if not data_dir.is_dir():
        raise UserError(
            f"data folder not found: {data_dir} (--root_dir {args.root_dir}, --data_dir "
            f"{args.data_dir}); record episodes first or fix the flags"
        )
    out_dir = Path(args.output_dir).expanduser()
    if not out_dir.is_absolute():
        out_dir = data_dir / out_dir
    check_writable_dir(out_dir, "--output_dir")  # before reading any episode
    found = list_episodes(data_dir)
    if not found:
        raise UserError(f"no episode_<k>.hdf5 files in {data_dir}; record episodes first")
    if args.episode_idx is not None:
        valid = [idx for idx, _ in found]
        found = [(idx, path) for idx, path in found if idx == args.episode_idx]
        if not found:
            raise UserError(
                f"no episode {args.episode_idx} in {data_dir}; available: "
                + ", ".join(map(str, valid))
            )

    # Validate every file before spending time on videos.
    episodes = [(idx, load_episode(path)) for idx, path in found]
    if any(ep.has_images for _, ep in episodes):
        h264_encoder()  # fails early with an install hint when PyAV is missing

    _make_output_dir(out_dir)
    written: list[Path] = []
    current: list[tuple[Path, int | None]] = []  # the file being written, its old mtime
    no_images: list[str] = []
    try:
        with folder_lock(out_dir):
            remove_stale_temps(out_dir, OWN_FILES)  # left by a run killed with SIGKILL
            with interrupt_note(lambda: _kept(written, out_dir, current)):
                _write_all(episodes, out_dir, args.fps, written, no_images, current)
    except FolderBusyError:
        raise UserError(
            f"another visualize is writing into {out_dir}; wait for it to finish or choose "
            "another --output_dir"
        ) from None
    videos = sum(path.suffix == ".mp4" for path in written)
    plots = len(written) - videos

    if no_images:
        print(
            f"note: {len(no_images)} episode(s) have no camera images "
            f"({', '.join(no_images[:5])}{', ...' if len(no_images) > 5 else ''}); "
            "wrote joint plots only for them"
        )
    print(f"wrote {videos} video(s) and {plots} joint plot(s) to {out_dir}")
    return 0


def _make_output_dir(out_dir: Path) -> None:
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(
            f"cannot create --output_dir {out_dir}: {describe_os_error(exc)}; "
            f"{os_error_hint(exc, '--output_dir')}"
        ) from None


def _mtime(path: Path) -> int | None:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return None


def _write_all(
    episodes, out_dir: Path, fps: float, written: list, no_images: list, current: list
) -> None:
    """Write every episode's video and plot, appending each finished file to ``written``;
    ``current`` holds the file being written and its modification time before (a signal
    can land after its rename and before the append)."""
    with tqdm(episodes, desc="visualize", unit="episode", file=sys.stderr) as bar:
        for idx, episode in bar:
            targets = []
            if episode.has_images:
                targets.append((write_episode_video, out_dir / f"episode_{idx}.mp4", {"fps": fps}))
            else:
                no_images.append(episode.path.name)
            targets.append((plot_joints, out_dir / f"episode_{idx}_joints.png", {}))
            for write, path, kwargs in targets:
                current[:] = [(path, _mtime(path))]
                try:
                    write(episode, path, **kwargs)
                except OSError as exc:
                    raise UserError(
                        f"cannot write {path}: {describe_os_error(exc)}; "
                        f"{os_error_hint(exc, '--output_dir')}; {_kept(written, out_dir)}"
                    ) from None
                written.append(path)
                current.clear()


def _kept(written: list[Path], out_dir: Path, current: list | tuple = ()) -> str:
    """What a stopped run kept: the finished files (the one in progress is removed). A file
    of ``current`` whose modification time changed was published just before the stop."""
    written = list(written) + [
        p for p, before in current if (now := _mtime(p)) is not None and now != before
    ]
    if not written:
        return f"no file was finished in {out_dir}"
    videos = sum(path.suffix == ".mp4" for path in written)
    return (
        f"kept {videos} finished video(s) and {len(written) - videos} joint plot(s) in "
        f"{out_dir} (last: {written[-1].name}); the file in progress was removed"
    )


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
