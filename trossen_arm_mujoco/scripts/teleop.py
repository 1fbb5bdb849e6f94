"""Teleoperate the simulated kit from two leader arms, recording episodes (also
``trossen-mujoco teleop``).

The leader arms (real ones, or the simulated pair of ``trossen-mujoco serve --role leader``)
are read through ``trossen_arm`` in external_effort mode; their joints drive the task's
simulated followers at ``--fps`` (default 50 Hz) within the real arms' joint and speed
limits, and every step is recorded as ``record`` records it, into
``<root_dir>/<data_dir>/episode_<k>.hdf5`` (continuing the folder's numbering; object poses
from ``--seed`` as ``record``'s episode ``k``). Keys on stdin: Enter starts an episode,
``e`` ends and keeps it, ``d`` discards it, ``q`` stops. A failing leader ends the run with
one ``error:`` line (exit 1); Ctrl-C or SIGTERM with 130 / 143; finished episodes are kept.

Docs: docs/cli/teleop.md.
"""

from __future__ import annotations

__all__ = ["EXIT_LEADER_FAULT", "StdinControl", "build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import math
import queue
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS
from trossen_arm_mujoco.errors import (
    ArgumentParser,
    UserError,
    interrupt_note,
    report_error,
    run_cli,
    unknown_name_error,
)
from trossen_arm_mujoco.scripts.common_options import (
    MAX_EPISODE_LEN,
    MAX_EPISODES,
    add_cameras,
    add_compression,
    add_data_dir,
    add_episode_len,
    add_fps,
    add_image_size,
    add_looks,
    add_num_episodes,
    add_root_dir,
    add_seed,
    add_task_name,
    add_viewer,
    camera_names,
    check_seed,
    dataset_folder,
    image_size,
)

#: Exit status when a leader arm failed.
EXIT_LEADER_FAULT = 1


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``trossen-mujoco teleop``."""
    p = ArgumentParser(
        prog="trossen-mujoco teleop",
        description="Teleoperate the simulated Stationary AI kit from two leader arms "
        "(real, or served by 'trossen-mujoco serve --role leader') and record HDF5 episodes.",
    )
    p.add_argument("--leader_left_ip", required=True, help="address of the left leader arm")
    p.add_argument("--leader_right_ip", required=True, help="address of the right leader arm")
    add_task_name(p, "kit task")
    add_data_dir(p)
    add_root_dir(p)
    add_num_episodes(p, "episodes to record in this run", 1)
    add_episode_len(
        p,
        "most steps per episode",
        "the task's, 600 for sim_transfer_cube, at 50 Hz; the same duration at another --fps",
    )
    add_cameras(p, "cameras to record", "all 4; rendering must keep up with --fps")
    add_image_size(p)
    add_fps(p, "recording and control rate in Hz", "the task's, 50")
    add_seed(p, "run seed: episode k's object poses are those of 'record --seed' episode k")
    p.add_argument(
        "--object_poses_from",
        default=None,
        metavar="EPISODE.hdf5",
        help="place the objects as at the start of this recorded episode, in every episode",
    )
    add_viewer(p)
    p.add_argument(
        "--end_effector",
        default="wxai_v0_leader",
        help="trossen_arm StandardEndEffector preset of the leader arms (default: wxai_v0_leader)",
    )
    p.add_argument(
        "--connect_timeout",
        type=float,
        default=10.0,
        help="seconds to wait for each leader arm's controller (default: 10)",
    )
    add_compression(p)
    add_looks(p, visual=False)
    p.add_argument(
        "--verbose", action="store_true", help="print the trossen_arm driver's own log lines"
    )
    return p


class StdinControl:
    """The operator's keys: lines of ``stream`` read in a daemon thread.

    ``interactive`` (a terminal): :meth:`wait_start` waits for Enter (True) or ``q``
    (False); otherwise it returns True at once. :meth:`poll` gives ``"end"`` for an ``e``
    line, ``"discard"`` for ``d``, None otherwise (stdin closed or unreadable: None).
    """

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = sys.stdin if stream is None else stream
        try:
            self.interactive = bool(self.stream.isatty())
        except (AttributeError, ValueError, OSError):
            self.interactive = False
        self.lines: queue.Queue[str | None] = queue.Queue()
        thread = threading.Thread(target=self._read, name="teleop-keys", daemon=True)
        thread.start()

    def _read(self) -> None:
        try:
            for line in self.stream:
                self.lines.put(line.strip().lower())
        except Exception:  # closed, or not readable (a test runner's stdin)
            pass
        self.lines.put(None)

    def _drain(self) -> list[str | None]:
        out = []
        while True:
            try:
                out.append(self.lines.get_nowait())
            except queue.Empty:
                return out

    def wait_start(self, index: int) -> bool:
        """Wait for Enter before episode ``index``: True to start, False when the
        operator typed ``q`` or stdin closed (always True when stdin is not a terminal)."""
        if not self.interactive:
            return True
        self._drain()  # keys pressed meanwhile do not count
        print(f"episode {index}: press Enter to start (q + Enter to stop)", flush=True)
        line = self.lines.get()
        return line is not None and line not in ("q", "quit")

    def poll(self) -> str | None:
        """The operator's command typed since the last poll: ``"end"`` (e), ``"discard"``
        (d), or None."""
        for line in self._drain():
            if line in ("e", "end"):
                return "end"
            if line in ("d", "discard"):
                return "discard"
        return None


def _viewer_hook(holder: list):
    from trossen_arm_mujoco.viewer import LiveViewer

    def hook(t: int, observation: dict, scene: Any, images: dict) -> None:
        if not holder:
            holder.append(LiveViewer.open(scene.model, scene.data))
        if holder[0] is not None:
            holder[0].update(images or None)

    return hook


def _rate(args: argparse.Namespace, task_name: str) -> tuple[float, dict[str, float]]:
    """(fps, task config overrides for it)."""
    from trossen_arm_mujoco.tasks import registry

    native = 1.0 / float(registry.load(task_name).load_config().get("policy_dt", 0.02))
    if args.fps is None or math.isclose(args.fps, native):
        return native, {}
    from trossen_arm_mujoco.eval.env import rate_timing

    return float(args.fps), rate_timing(args.fps)


def main(argv: Sequence[str] | None = None) -> int:
    """Teleoperate and record the episodes ``argv`` asks for. Returns the exit status;
    user mistakes raise ``UserError``."""
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.tasks.registry import ALIASES, kit_names

    task_name = ALIASES.get(args.task_name, args.task_name)
    if task_name not in kit_names():
        raise unknown_name_error("kit task", task_name, kit_names())
    config = SIM_TASK_CONFIGS[task_name]
    fps, overrides = _rate(args, task_name)
    episode_len = args.episode_len
    if episode_len is None:
        episode_len = max(1, round(config["episode_len"] * fps / 50.0))
    if not 1 <= args.num_episodes <= MAX_EPISODES:
        raise UserError(f"--num_episodes must be in 1 .. {MAX_EPISODES}, got {args.num_episodes}")
    if not 1 <= episode_len <= MAX_EPISODE_LEN:
        raise UserError(f"--episode_len must be in 1 .. {MAX_EPISODE_LEN}, got {episode_len}")
    check_seed(args.seed)
    if not (math.isfinite(args.connect_timeout) and args.connect_timeout > 0):
        raise UserError(f"--connect_timeout must be a positive number, got {args.connect_timeout}")
    cams = camera_names(args.cam_names, task_name)
    height, width = image_size(args.image_size)

    from trossen_arm_mujoco.twin.leader_arms import LeaderArms
    from trossen_arm_mujoco.twin.teleop import TeleopSettings, object_poses_from

    poses = None
    if args.object_poses_from is not None:
        poses = object_poses_from(args.object_poses_from, task_name)
    leaders = LeaderArms(
        {"left": args.leader_left_ip, "right": args.leader_right_ip},
        end_effector=args.end_effector,
        timeout=args.connect_timeout,
        verbose=args.verbose,
    )
    settings = TeleopSettings(
        task_name=task_name,
        episode_len=episode_len,
        cam_names=cams,
        height=height,
        width=width,
        compression=args.compression,
        overrides=overrides,
        shadows=not args.no_shadows,
        antialias=not args.no_antialias,
    )
    folder = dataset_folder(args.root_dir, args.data_dir)
    from trossen_arm_mujoco.data.dataset_lock import DatasetLock

    with DatasetLock(folder):
        return _teleop(args, settings, folder, leaders, poses, fps)


def _teleop(args, settings, folder: Path, leaders, poses, fps: float) -> int:
    """The run, inside the folder's lock."""
    from trossen_arm_mujoco.collect.parallel import format_size
    from trossen_arm_mujoco.collect.pipeline import episode_seed
    from trossen_arm_mujoco.collect.resume import format_indices
    from trossen_arm_mujoco.data.reader import episode_path, list_episodes
    from trossen_arm_mujoco.data.temp_files import remove_stale_temp_files
    from trossen_arm_mujoco.twin.leader_arms import LeaderFault
    from trossen_arm_mujoco.twin.teleop import TeleopRecorder

    remove_stale_temp_files(folder)
    existing = [k for k, _ in list_episodes(folder)]
    first = max(existing) + 1 if existing else 0
    kept: list[int] = []
    state = {"index": first, "recording": False}

    def summary() -> str:
        done = sorted(existing + kept)
        where = f"{format_indices(done)} in {folder}" if done else f"none in {folder}"
        lost = f"episode {state['index']} in progress discarded; " if state["recording"] else ""
        return f"{lost}{len(kept)} new episode(s) kept; dataset: {where}"

    viewer: list = []
    hook = _viewer_hook(viewer) if args.viewer else None
    control = StdinControl()
    print(
        f"teleop '{settings.task_name}' at {fps:g} Hz, up to {settings.episode_len} steps per "
        f"episode, cameras: {', '.join(settings.cam_names) or 'none'}; leaders: left "
        f"{leaders.ips['left']}, right {leaders.ips['right']}; recording episodes from "
        f"{first} into {folder}",
        flush=True,
    )
    recorder = None
    successes = 0
    try:
        with interrupt_note(summary):
            recorder = TeleopRecorder(settings, hook)  # the slow part, before connecting
            leaders.connect()
            leaders.read()
            while len(kept) < args.num_episodes:
                index = state["index"]
                if not control.wait_start(index):
                    break
                keys = (
                    " (e + Enter: end and keep, d + Enter: discard)" if control.interactive else ""
                )
                print(f"episode {index}: recording{keys}", flush=True)
                state["recording"] = True
                outcome = recorder.record_episode(
                    index,
                    episode_seed(args.seed, index),
                    episode_path(folder, index),
                    leaders,
                    control,
                    object_poses=poses,
                    extra_attrs={"base_seed": int(args.seed)},
                )
                state["recording"] = False
                if outcome is None:
                    print(f"episode {index}: discarded", flush=True)
                    continue
                kept.append(index)
                successes += outcome.success
                state["index"] = index + 1
                print(_episode_line(outcome, format_size), flush=True)
                if outcome.achieved_fps < 0.95 * fps:
                    print(_slow_warning(outcome, fps, settings), file=sys.stderr, flush=True)
    except LeaderFault as fault:
        return report_error(f"{fault}; {summary()}", EXIT_LEADER_FAULT)
    except UserError as exc:  # a write the file system refused, a scene that cannot be drawn
        return report_error(f"{exc}; {summary()}")
    finally:
        leaders.close()
        if recorder is not None:
            recorder.close()
        if viewer and viewer[0] is not None:
            viewer[0].close()
    print(f"recorded {len(kept)} episode(s); Success: {successes} / {len(kept)}; {summary()}")
    return 0


def _slow_warning(o, fps: float, settings) -> str:
    """The loop fell behind the wall clock: simulated time ran slower than the leaders'."""
    cause = (
        "record fewer or smaller cameras (--cam_names, --image_size) or use --no_shadows"
        if settings.cam_names
        else "the machine is busy"
    )
    return (
        f"warning: episode {o.index} ran at {o.achieved_fps:.1f} Hz, below {fps:g} Hz "
        f"({o.overruns} late steps): the simulation ran slower than real time, so the "
        f"recorded motion is faster than the operator's and more of it was speed-limited; "
        f"{cause}"
    )


def _episode_line(o, format_size) -> str:
    verdict = "success" if o.success else "not successful"
    return (
        f"episode {o.index}: {o.num_steps} steps (ended by {o.ended_by.replace('_', ' ')}), "
        f"reward {o.final_reward:g} (max {o.max_reward:g} of {o.task_max_reward:g}), {verdict}; "
        f"tracking RMS {o.tracking_rms:.4f} rad after a {o.ramp_steps}-step ramp, "
        f"{o.speed_limited_values} speed-limited values; {o.achieved_fps:.1f} Hz "
        f"({o.overruns} late steps) -> {o.path} ({format_size(o.nbytes)})"
    )


def cli(argv: Sequence[str] | None = None) -> int:
    """``main`` with one-line errors and signal handling (``errors.run_cli``); the exit status."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
