"""Serve the simulated kit over the arm controller's wire protocol (also ``trossen-mujoco serve``).

    trossen-mujoco serve                       # left arm on 127.0.0.2, right arm on 127.0.0.3
    trossen-mujoco serve --record demo --cam_names cam_high --image_size 240x320
    trossen-mujoco serve --task_name pick_place --ip 127.0.0.2   # the single WidowX AI arm

One kit world (or a single arm's task's one arm) steps in real time; each arm answers the
``trossen_arm`` driver on its own loopback address (127.0.0.0/8 only) as a real arm
controller does. ``--record DIR`` writes the clients' sessions as episodes; ``--cameras``
and ``--control_port`` rehearse a deployment (ZeroMQ cameras, an episode control channel);
``--role leader --replay EPISODE.hdf5`` serves two leader arms replaying an episode. Ctrl-C,
SIGTERM, SIGHUP or SIGQUIT stops serving cleanly (exit 0), the episode under way written.

Docs: docs/cli/serve.md, docs/rehearsal.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

__all__ = ["LEADER_IPS", "build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import logging
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from trossen_arm_mujoco.errors import ArgumentParser, UserError, run_cli
from trossen_arm_mujoco.scripts.common_options import (
    add_cameras,
    add_compression,
    add_episode_len,
    add_fps,
    add_image_size,
    add_looks,
    add_randomize,
    add_root_dir,
    add_seed,
    add_task_name,
    add_viewer,
    add_wait,
    check_seed,
)
from trossen_arm_mujoco.scripts.serve_rehearsal import (
    add_rehearsal_flags,
    build_rehearsal,
    check_rehearsal_flags,
    stop_rehearsal,
)
from trossen_arm_mujoco.stopping import StopSignals

#: Default addresses of served leader arms (``--role leader``).
LEADER_IPS: dict[str, str] = {"left": "127.0.0.4", "right": "127.0.0.5"}


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    p = ArgumentParser(
        prog="trossen-mujoco serve",
        description="Serve the simulated Stationary AI kit over the arm controller's wire "
        "protocol on loopback addresses, so that trossen_arm clients drive it like the real "
        "kit; optionally record what they do.",
    )
    add_task_name(p, "kit task whose objects and reward the world holds")
    p.add_argument(
        "--left_ip",
        default=None,
        help="left arm's address in 127.0.0.0/8 (default 127.0.0.2; leaders 127.0.0.4)",
    )
    p.add_argument(
        "--right_ip",
        default=None,
        help="right arm's address in 127.0.0.0/8 (default 127.0.0.3; leaders 127.0.0.5)",
    )
    p.add_argument(
        "--ip",
        default=None,
        help="a single arm's task (push, pick_place, reach): the arm's address in "
        "127.0.0.0/8 (default --left_ip's, 127.0.0.2)",
    )
    add_seed(p, "run seed: the scene of episode k is record --seed S's episode k")
    add_viewer(p, "show a live viewer (needs a display)")
    p.add_argument(
        "--record",
        default=None,
        metavar="DIR",
        help="record the clients' sessions into this dataset folder (relative to "
        "--root_dir unless absolute); episodes continue after its last one",
    )
    add_root_dir(p)
    add_cameras(p, "cameras to record (with --record)", "the task's 4")
    add_image_size(p, "camera image size (with --record, --cameras)")
    add_fps(
        p, "recording rate in frames per simulated second; 500/n, e.g. 50 or 25", "the task's, 50"
    )
    add_episode_len(
        p,
        "with --record: at most this many frames per episode; a longer session is split",
        "one episode per session",
    )
    add_compression(p)
    add_looks(p, visual=False)
    add_randomize(p, "the control channel's start reply ('randomization')")
    add_wait(p, "with --record: wait for another run writing to DIR instead of refusing")
    p.add_argument(
        "--role",
        default="follower",
        choices=("follower", "leader"),
        help="follower: the kit world (default); leader: two leader arms replaying --replay",
    )
    p.add_argument(
        "--replay",
        default=None,
        metavar="EPISODE",
        help="with --role leader: the episode file the leaders replay",
    )
    p.add_argument(
        "--speed", type=float, default=1.0, help="with --role leader: replay speed (default 1)"
    )
    p.add_argument(
        "--lead_in",
        type=float,
        default=None,
        metavar="SECONDS",
        help="with --role leader: seconds the leaders stay still after a client puts both in "
        "external_effort mode, before they move (default 1; lerobot-teleoperate connects its "
        "followers after the leaders: give it 8)",
    )
    add_rehearsal_flags(p)
    p.add_argument("--verbose", action="store_true", help="log every protocol request")
    p.add_argument(
        "--parent_pid",
        type=int,
        default=None,
        metavar="PID",
        help="stop serving (as on SIGTERM) once process PID is no longer serve's "
        "parent, e.g. killed; eval --backend wire passes its own",
    )
    return p


def _say(text: str) -> None:
    try:
        print(text, flush=True)
    except (OSError, ValueError):  # a closed stdout must not stop serving
        pass


def _ips(args: argparse.Namespace, defaults: dict[str, str]) -> dict[str, str]:
    from trossen_arm_mujoco.twin.served_kit import check_kit_ips

    given = {"left": args.left_ip or defaults["left"], "right": args.right_ip or defaults["right"]}
    return check_kit_ips(given, {"left": "--left_ip", "right": "--right_ip"})


def _single_arm(task: str) -> bool:
    """Whether ``task`` is a single arm's (served by ``twin.arm_world.ArmWorld``)."""
    from trossen_arm_mujoco.twin.arm_world import is_arm_world_task

    return is_arm_world_task(task)


def _arm_ips(args: argparse.Namespace) -> dict[str, str]:
    """A single arm's address (``--ip``, else ``--left_ip``, else 127.0.0.2), checked;
    ``--right_ip`` and ``--record`` are the kit's (one line otherwise)."""
    from trossen_arm_mujoco.twin.arm_world import ARM_SIDE
    from trossen_arm_mujoco.twin.serving import check_loopback

    task = args.task_name
    if args.right_ip is not None:
        raise UserError(
            f"--right_ip: task '{task}' serves one arm; give its address with --ip (or --left_ip)"
        )
    if args.ip is not None and args.left_ip is not None and args.ip != args.left_ip:
        raise UserError("--ip and --left_ip both name the single arm's address; give one")
    if args.record is not None:
        raise UserError(
            f"--record records the Stationary AI kit's sessions; task '{task}' is a single "
            "arm's: record it with trossen-mujoco record --task_name " + task
        )
    flag = "--ip" if args.ip is not None else "--left_ip"
    return {ARM_SIDE: check_loopback(args.ip or args.left_ip or "127.0.0.2", flag)}


def main(argv: Sequence[str] | None = None) -> int:
    """Parse, serve until a stop signal; returns the exit status (0 after a deliberate
    stop). The stop signals' handlers are put back before it returns."""
    return _main(argv, StopSignals())


def _main(argv: Sequence[str] | None, stops: StopSignals, keep: bool = False) -> int:
    """:func:`main`; with ``keep`` the stop handlers are left installed (the caller,
    :func:`cli`, puts them back unless serving began: ``stops.keep``)."""
    try:
        return _parse_and_serve(argv, stops)
    finally:
        if not keep:
            stops.restore()


def _parse_and_serve(argv: Sequence[str] | None, stops: StopSignals) -> int:
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.twin.serving import require_sim_server

    if args.parent_pid is not None and args.parent_pid < 1:
        raise UserError(f"--parent_pid must be a process id (at least 1), got {args.parent_pid}")
    stops.watch_parent(args.parent_pid)
    require_sim_server()
    logging.basicConfig(format="%(name)s: %(message)s")
    level = logging.INFO if args.verbose else logging.WARNING
    for name in ("trossen_arm_sim", "trossen_arm_mujoco.twin"):
        logging.getLogger(name).setLevel(level)
    if args.ip is not None and (args.role == "leader" or not _single_arm(args.task_name)):
        raise UserError(
            "--ip is a single arm's address (--task_name push, pick_place, reach); the "
            "kit's arms take --left_ip and --right_ip"
        )
    if args.role == "leader":
        if args.cameras is not None or args.control_port is not None:
            raise UserError("--cameras and --control_port need --role follower")
        return _serve_leaders(args, stops)
    if args.replay is not None:
        raise UserError("--replay needs --role leader")
    if args.lead_in is not None:
        raise UserError("--lead_in needs --role leader")
    check_rehearsal_flags(args)
    from trossen_arm_mujoco.twin.served_kit import DEFAULT_IPS

    ips = _arm_ips(args) if _single_arm(args.task_name) else _ips(args, DEFAULT_IPS)
    check_seed(args.seed)
    if args.episode_len is not None and args.episode_len < 1:
        raise UserError(f"--episode_len must be at least 1, got {args.episode_len}")
    if args.record is None:
        for flag in ("cam_names", "episode_len", "wait"):
            if getattr(args, flag):
                raise UserError(f"--{flag} needs --record DIR")
        stops.install()
        return _serve(args, ips, None, stops)
    from trossen_arm_mujoco.data.dataset_lock import DatasetLock
    from trossen_arm_mujoco.scripts.common_options import camera_names as _cameras
    from trossen_arm_mujoco.scripts.common_options import dataset_folder as _dataset_folder
    from trossen_arm_mujoco.scripts.common_options import image_size as _image_size

    cams = _cameras(args.cam_names, _task(args.task_name))
    size = _image_size(args.image_size)
    folder = _dataset_folder(args.root_dir, args.record)
    stops.install()  # a stop signal is now a request: the shutdown runs to its end
    lock = DatasetLock(folder, wait=args.wait)
    try:
        with stops.interruptible():  # only an exception ends a wait for the lock (--wait)
            lock.acquire()
    except KeyboardInterrupt:
        lock.release()
        _say(f"stopped ({stops.reason}) before serving began; nothing was recorded")
        return 0
    try:
        return _serve(args, ips, (folder, cams, size), stops)
    finally:
        lock.release()


def _task(name: str) -> str:
    from trossen_arm_mujoco.tasks.registry import canonical

    return canonical(name)


def _serve(args: argparse.Namespace, ips: dict[str, str], record, stops: StopSignals) -> int:
    from trossen_arm_mujoco.twin.kit_world import KitWorld
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    first = 0
    if record is not None:
        first = _first_index(record[0])
    if stops.requested:
        return _stopped_early(stops)
    from trossen_arm_mujoco.scripts.common_options import randomization_of, scene_looks

    randomize, randomization = randomization_of(args, args.task_name)
    world_cls = KitWorld
    if _single_arm(args.task_name):
        from trossen_arm_mujoco.twin.arm_world import ArmWorld

        world_cls = ArmWorld
    world = world_cls(
        args.task_name,
        base_seed=args.seed,
        episode_index=first,
        fps=args.fps,
        looks=scene_looks(args),
        randomize=randomize,
        randomization=randomization,
    )
    recorder = None
    try:
        if stops.requested:
            return _stopped_early(stops)
        if record is not None:
            from trossen_arm_mujoco.twin.session_recorder import RecordOptions, SessionRecorder

            folder, cams, (h, w) = record
            options = RecordOptions(folder, cams, h, w, args.compression, args.episode_len)
            recorder = SessionRecorder(world, options, first, _say)
        stream, control = build_rehearsal(args, world, recorder, _say)
        kit = ServedKit(world, ips, _say, recorder)
        kit.sessions_from_clients = control is None
        # The window opens before the kit serves: opening it can take seconds (software GL)
        # and a driver connecting meanwhile would time out waiting for its first joint outputs.
        viewer = _open_viewer(world) if args.viewer else None
        try:
            kit.start()
            for part in (stream, control):
                if part is not None:
                    part.start()
        except BaseException:
            stop_rehearsal(stream, control, _say)
            kit.stop()
            if viewer is not None:
                viewer.close()
            raise
        stops.keep = True  # serving: once it ends, the process ends
        started = time.monotonic()
        try:
            arms = (
                f"left arm on {ips['left']}, right arm on {ips['right']}"
                if "left" in ips
                else f"the arm on {next(iter(ips.values()))}"
            )
            _say(
                f"serving {world.task_name} (seed {args.seed}, episode {first}): {arms} "
                "(TCP 50001, UDP 50000)"
                + (f"; recording into {record[0]}" if record else "")
                + (f"; cameras {','.join(stream.cam_names)} on {stream.address}" if stream else "")
                + (f"; episode control on {control.host}:{control.port}" if control else "")
                + "; Ctrl-C stops"
            )
            how = _wait(world, viewer, stops)
        finally:
            stop_rehearsal(stream, control, _say)
            stats = kit.stop(lambda: _report_repeats(stops, recorder))
        rtf = world.realtime_factor
        line = (
            f"stopped ({how}) after {time.monotonic() - started:.1f} s at real-time "
            f"factor {rtf:.2f}"
        )
        if stats is not None:
            line += (
                f"; {len(stats.written)} episode(s) written to {record[0]}, "
                f"{stats.successes} successful"
            )
            if stats.frames and record[1]:
                line += f"; frames rendered at {stats.frames_per_s:.1f} per s"
        _say(line)
        if stats is not None and stats.errors:
            raise UserError(f"{len(stats.errors)} episode(s) not written: {stats.errors[0]}")
        return 0
    finally:
        world.close()


def _stopped_early(stops: StopSignals) -> int:
    _say(f"stopped ({stops.reason}) before serving began")
    return 0


def _report_repeats(stops: StopSignals, recorder) -> None:
    """While the shutdown runs (main thread): one line for signals received after the first."""
    names = stops.new_repeats()
    if not names:
        return
    what = "still stopping"
    if recorder is not None:
        what += f": writing the recording ({recorder.backlog} frames queued)"
    _say(f"{', '.join(names)} received: {what}; nothing is cut short, serve exits when done")


def _first_index(folder: Path) -> int:
    """Index after the folder's last episode (nothing is overwritten). First (the caller
    holds the lock), the temporary episode files killed runs left are removed, and the
    episodes they left in spools are published (or, when that fails, kept with a line
    saying how to recover them)."""
    from trossen_arm_mujoco.data.reader import list_episodes
    from trossen_arm_mujoco.data.temp_files import remove_stale_temp_files
    from trossen_arm_mujoco.twin.spool_recovery import recover_spools

    def next_index() -> int:
        found = list_episodes(folder, missing_ok=True)
        return found[-1][0] + 1 if found else 0

    remove_stale_temp_files(folder)
    recover_spools(folder, next_index, _say)
    return next_index()


def _open_viewer(world):
    """The live viewer on the world, or None (with a note) where no window opens."""
    from trossen_arm_mujoco.viewer import LiveViewer

    with world.lock:  # the viewer reads the data while it starts: not mid-step
        return LiveViewer.open(world.model, world.data)


def _wait(world, viewer, stops: StopSignals) -> str:
    """Until a stop signal (returns its name) or the viewer window (closed here) closes."""
    try:
        while not stops.requested:
            if viewer is None:
                stops.wait(0.5)
                continue
            with world.lock:
                running = viewer.update()
            if not running:
                return "viewer closed"
            time.sleep(1 / 30)
        return stops.reason
    finally:
        if viewer is not None:
            viewer.close()


def _serve_leaders(args: argparse.Namespace, stops: StopSignals) -> int:
    """``--role leader``: two leader arms replaying ``--replay`` (``twin.leaders``)."""
    if args.record is not None:
        raise UserError("--record needs --role follower")
    if args.replay is None:
        raise UserError("--role leader needs --replay EPISODE.hdf5 (the motion the leaders make)")
    ips = _ips(args, LEADER_IPS)
    try:
        from trossen_arm_mujoco.twin.leaders import serve_leaders
        from trossen_arm_mujoco.twin.replay_clock import LEAD_IN_S
    except ImportError as exc:
        raise UserError(f"--role leader is not available in this installation ({exc})") from None
    stop, failure = threading.Event(), []
    stops.install()

    def run() -> None:
        try:
            serve_leaders(
                args.replay,
                ips["left"],
                ips["right"],
                stop,
                speed=args.speed,
                lead_in=LEAD_IN_S if args.lead_in is None else args.lead_in,
            )
        except BaseException as exc:  # reported below, in the main thread
            failure.append(exc)

    worker = threading.Thread(target=run, name="leaders", daemon=True)
    worker.start()
    stops.keep = True  # serving: once it ends, the process ends
    how = "replay ended"
    try:
        while worker.is_alive() and not stops.requested:
            worker.join(0.2)
        if stops.requested:
            how = stops.reason
    finally:
        stop.set()
        while worker.is_alive():
            worker.join(0.2)
            _report_repeats(stops, None)
    if failure:
        exc = failure[0]
        raise UserError(str(exc)) if isinstance(exc, UserError) else exc
    _say(f"leaders stopped ({how})")
    return 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point of the process (``trossen-mujoco serve``): user errors as one line and
    exit status 2; any number of stop signals end serving with exit status 0. Once serving
    began (or a stop was requested), the stop signals are ignored when it returns: the
    process is about to exit, and a late signal must not turn a clean stop into exit status
    143 or a traceback."""
    stops = StopSignals().install()  # first: run_cli puts it back after main

    try:
        return run_cli(lambda args: _main(args, stops, keep=True), argv)
    finally:
        if stops.keep or stops.requested:
            stops.ignore()
        else:
            stops.restore()


if __name__ == "__main__":
    sys.exit(cli())
