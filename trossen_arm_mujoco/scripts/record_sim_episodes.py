"""Record scripted demonstrations into HDF5 episodes (also ``trossen-mujoco record``).

    python trossen_arm_mujoco/scripts/record_sim_episodes.py --data_dir demo --num_episodes 2

Phase 1 runs the scripted policy in the end-effector env (no rendering); phase 2 replays the
joint trajectory in the joint env, rendering the requested cameras and streaming every step
to ``<root_dir>/<data_dir>/episode_<k>.hdf5``. Unset flags come from
``SIM_TASK_CONFIGS[task_name]``. One run writes to a folder at a time (``--wait`` waits); a
rerun checks the episodes there and records the missing and the failed ones. The exit status
is 1 when some failed; Ctrl-C or SIGTERM keeps every finished episode; a refused write ends
the run with one ``error:`` line and no partial file.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

__all__ = ["cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from trossen_arm_mujoco.collect.resume import format_indices
from trossen_arm_mujoco.errors import run_cli
from trossen_arm_mujoco.scripts.common_options import dataset_folder
from trossen_arm_mujoco.scripts.record_args import build_parser, record_options
from trossen_arm_mujoco.stopping import redeliver_if_in_finalizer

if TYPE_CHECKING:
    import argparse

    from trossen_arm_mujoco.collect.parallel import DatasetRecorder


def _on_wait(folder: Path):
    def say(pid, host) -> None:
        from trossen_arm_mujoco.data.dataset_lock import holder_text

        print(
            f"waiting for the record run ({holder_text(pid, host)}) writing to {folder} to "
            "finish (Ctrl-C to stop waiting)",
            file=sys.stderr,
            flush=True,
        )

    return say


def _raise_hangup(signum, frame):  # a closed terminal: the same clean path as Ctrl-C
    if redeliver_if_in_finalizer(signum, frame):
        return
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    """Record the episodes ``argv`` asks for into the dataset folder (locked while
    recording). Returns the exit status; user mistakes raise ``UserError``."""
    args = build_parser().parse_args(argv)
    dataset_folder(args.root_dir, args.data_dir, create=False)  # first, before any work
    options = record_options(args)
    settings, num_episodes, onscreen = options.settings, options.num_episodes, options.onscreen
    folder = dataset_folder(args.root_dir, args.data_dir)
    from trossen_arm_mujoco.data.dataset_lock import DatasetLock

    hangup = _catch_hangup()
    try:
        with DatasetLock(folder, wait=args.wait, on_wait=_on_wait(folder)):
            return _record(args, settings, folder, num_episodes, onscreen)
    finally:
        if hangup is not None:
            signal.signal(signal.SIGHUP, hangup)


def _catch_hangup():
    """SIGHUP (the terminal closed) ends the run like Ctrl-C; returns the previous handler."""
    import threading

    sighup = getattr(signal, "SIGHUP", None)
    if sighup is None or threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(sighup)
    if previous == signal.SIG_IGN:  # nohup: keep running
        return None
    signal.signal(sighup, _raise_hangup)
    return signal.SIG_DFL if previous is None else previous


def _record(args, settings, folder: Path, num_episodes: int, onscreen: bool) -> int:
    """The run, inside the folder's lock."""
    from trossen_arm_mujoco.collect.pipeline import policy_minimum_episode_len
    from trossen_arm_mujoco.collect.resume import plan_run
    from trossen_arm_mujoco.scripts.record_report import (
        report_run,
        say_plan,
        warn_disk_space,
        warn_short_episodes,
    )

    plan = plan_run(folder, num_episodes, args.overwrite, settings)
    if not plan.indices:
        print(
            f"{folder} already holds {format_indices(plan.existing)}; nothing to record "
            "(raise --num_episodes to add more, or --overwrite to start afresh)"
        )
        return 0
    say_plan(plan, folder, num_episodes)
    episode_len = settings.episode_len
    minimum_len = policy_minimum_episode_len(args.task_name)
    warn_short_episodes(args.task_name, episode_len, minimum_len)
    warn_disk_space(folder, settings, len(plan.indices))
    print(
        f"recording {format_indices(plan.indices)} of '{args.task_name}' "
        f"({episode_len} steps, cameras: {', '.join(settings.cam_names) or 'none'}"
        f"{', randomized' if args.randomize else ''}) into {folder}"
    )

    viewer = None
    hook = None
    if onscreen:
        viewer, hook = _live_view_hook(settings)
    start = time.perf_counter()
    try:
        with _engine(args, hook) as make_recorder:
            recorder = make_recorder(
                settings, folder, skip_failed=args.skip_failed, overwrite=args.overwrite
            )
            report = recorder.run(num_episodes, plan)
    finally:
        if viewer is not None and viewer[0] is not None:
            viewer[0].close()
    wall = time.perf_counter() - start
    max_attempts = recorder.max_attempts(len(plan.indices))
    return report_run(
        args, report, max_attempts, plan, folder, num_episodes, wall, episode_len, minimum_len
    )


@contextmanager
def _engine(
    args: argparse.Namespace, step_hook: Callable | None
) -> Iterator[Callable[..., DatasetRecorder]]:
    """A recorder factory for ``--engine``; with Ray, connected for the block's duration."""
    from trossen_arm_mujoco.collect.parallel import DatasetRecorder

    if args.engine == "local":
        yield partial(DatasetRecorder, num_workers=args.num_workers or 1, step_hook=step_hook)
        return
    from trossen_arm_mujoco.collect.ray_engine import RayDatasetRecorder
    from trossen_arm_mujoco.collect.ray_session import ray_session

    with ray_session(args.ray_address, num_cpus=args.num_workers):
        yield partial(RayDatasetRecorder, max_in_flight=args.num_workers)


def _live_view_hook(settings):
    """A step hook that shows the joint scene and its camera images in a live viewer; the
    viewer is tried once (without a display, one line says so and the run goes on)."""
    from trossen_arm_mujoco.viewer import LiveViewer

    holder: list = [None, False]  # the viewer, whether it was tried

    def hook(t: int, observation: dict, scene) -> None:
        if not holder[1]:
            holder[1] = True
            holder[0] = LiveViewer.open(scene.model, scene.data)
        if holder[0] is not None:
            holder[0].update(observation.get("images"))

    return holder, hook


def cli(argv: Sequence[str] | None = None) -> int:
    """``main`` with one-line errors and signal handling (``errors.run_cli``); the exit status."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
