"""Replay a recorded episode on two real arms, or on their simulated twin.

The whole trajectory is validated first (shape, finite values, joint limits, joint
speeds at ``--fps``, which must be in [0.5, 1000] Hz: one command lasts at most 2 s);
any violation is one line and exit status 2, before any driver is created. Gripper
commands above ``--gripper_max`` (the controller's range, 0.04 m) are clamped and
counted. Then both arms are configured with the ``--end_effector`` preset, move to the
first action over 2 s, follow the actions at ``--fps``, and finally go home and to the
sleep pose; any error, or Ctrl-C, SIGTERM, SIGHUP or SIGQUIT (at any moment, within
0.05 s, even in the middle of a command period) stops streaming and still runs the
home/sleep/cleanup sequence on every configured arm, and the exit status is non-zero
(128 + the signal's number after a signal) with one line on stderr. Tracking results
(CSV, JSON summary, PNG) go to ``<data folder>/replay/``, whatever stopped the replay;
a signal arriving while the arms go home or the results are written is noted and
changes nothing, so the files are always complete. A signal before any arm was
configured ends the command at once. Also available as ``trossen-mujoco replay-real``.

Examples::

    # check an episode and print what would be sent; nothing moves
    python trossen_arm_mujoco/scripts/replay_episode_real.py --data_dir sim_transfer_cube \\
        --dry_run
    # rehearse on the simulated twin (faster than real time; --realtime: at the arms' pace)
    python trossen_arm_mujoco/scripts/replay_episode_real.py --data_dir sim_transfer_cube \\
        --backend sim
    # the real trossen_arm driver against the simulated kit, served here on 127.0.0.2 and
    # 127.0.0.3 in real time (needs: pip install 'trossen-arm-mujoco[twin]')
    python trossen_arm_mujoco/scripts/replay_episode_real.py --data_dir sim_transfer_cube \
        --backend wire
    # real arms (needs: pip install 'trossen-arm-mujoco[real]'); arms built in 2025
    python trossen_arm_mujoco/scripts/replay_episode_real.py --data_dir sim_transfer_cube \\
        --left_ip 192.168.1.5 --right_ip 192.168.1.4 --end_effector wxai_v0_follower_20250509
"""

from __future__ import annotations

__all__ = ["IP_FLAGS", "MAX_CONNECT_TIMEOUT_S", "build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import functools
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.collect.resume import format_indices
from trossen_arm_mujoco.constants import ROOT_DIR
from trossen_arm_mujoco.data.reader import (
    Episode,
    episode_path,
    list_episodes,
    load_episode,
    resolve_data_dir,
)
from trossen_arm_mujoco.errors import (
    ArgumentParser,
    UserError,
    describe_os_error,
    os_error_hint,
    report_error,
    run_cli,
)
from trossen_arm_mujoco.real.clock import Clock, SimClock
from trossen_arm_mujoco.real.driver import (
    CONNECT_TIMEOUT_S,
    DEFAULT_END_EFFECTOR,
    DEFAULT_MODEL,
    check_end_effector,
    find_trossen_arm,
    import_trossen_arm,
    installed_version,
    release_driver_logs,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX, clamp_gripper
from trossen_arm_mujoco.real.preflight import check_arm_ips, recorded_dt
from trossen_arm_mujoco.real.replay import (
    BACKENDS,
    MAX_FPS,
    MIN_FPS,
    DriverFactory,
    ReplayConfig,
    ReplayResult,
    check_fps,
    make_drivers,
    replay,
)
from trossen_arm_mujoco.real.report import (
    PLOT_HINT,
    check_outputs,
    format_error_table,
    write_outputs,
)
from trossen_arm_mujoco.real.stop import Interrupted, StopFlag, stop_on_signals
from trossen_arm_mujoco.real.validate import ArmLimits, format_trajectory_report, validate_actions

#: Longest ``--connect_timeout`` (s).
MAX_CONNECT_TIMEOUT_S: float = 600.0

#: The flag that sets each arm's address.
IP_FLAGS: dict[str, str] = {"left": "--left_ip", "right": "--right_ip"}


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    p = ArgumentParser(
        prog="trossen-mujoco replay-real",
        description="Replay a recorded episode on two Trossen AI arms (or their simulated "
        "twin), with validation, tracking-error logging and a safe home/sleep exit.",
    )
    p.add_argument(
        "--data_dir", required=True, help="dataset folder, relative to --root_dir unless absolute"
    )
    p.add_argument("--root_dir", default=ROOT_DIR, help=f"datasets root (default {ROOT_DIR})")
    p.add_argument("--episode_idx", type=int, default=0, help="episode to replay (default 0)")
    p.add_argument(
        "--fps",
        type=float,
        default=10.0,
        help=f"command rate in Hz, in [{MIN_FPS:g}, {MAX_FPS:g}]: one command lasts at most "
        f"{1 / MIN_FPS:g} s, the goal time trossen_arm gives a whole move (default 10)",
    )
    p.add_argument(
        "--left_ip", default=None, help="left arm (default 192.168.1.5; --backend wire: 127.0.0.2)"
    )
    p.add_argument(
        "--right_ip",
        default=None,
        help="right arm (default 192.168.1.4; --backend wire: 127.0.0.3)",
    )
    p.add_argument(
        "--backend",
        choices=BACKENDS,
        default="trossen",
        help="trossen: real arms via trossen_arm; sim: the MuJoCo twin; wire: the real "
        "trossen_arm driver against the simulated kit served on loopback addresses (started "
        "here, in real time; needs trossen-arm-mujoco[twin]) (default trossen)",
    )
    p.add_argument(
        "--realtime",
        action="store_true",
        help="with --backend sim: run the twin at the real arms' pace (wall-clock time) "
        "instead of as fast as it simulates; real arms always run in real time",
    )
    p.add_argument(
        "--goal_time_factor",
        type=float,
        default=3.0,
        help="goal time of each command, in command periods (default 3: goal time 3/fps)",
    )
    p.add_argument(
        "--end_effector",
        default=DEFAULT_END_EFFECTOR,
        help=f"end-effector preset: a trossen_arm.StandardEndEffector member of the installed "
        f"trossen_arm, read at run time; an unknown name fails, listing the valid ones "
        f"(default {DEFAULT_END_EFFECTOR}, the current follower preset; arms built in 2025 "
        f"need wxai_v0_follower_20250509). With --backend sim or --dry_run it is checked the "
        f"same way when trossen_arm is installed and accepted unchecked, with a note, when it "
        f"is not; the simulated twin models the follower gripper whatever the preset",
    )
    p.add_argument(
        "--gripper_max",
        type=float,
        default=GRIPPER_MAX,
        help=f"largest gripper command sent (m); the arm controller's range ends at "
        f"{GRIPPER_MAX:g} m while recordings reach 0.044 m. Larger commands are clamped to it "
        f"and counted in the summary (default {GRIPPER_MAX:g})",
    )
    p.add_argument(
        "--output_dir",
        default=None,
        help="folder of the tracking-error CSV, JSON summary and plot, checked for writing "
        "before any arm moves (default: <data folder>/replay)",
    )
    p.add_argument(
        "--connect_timeout",
        type=float,
        default=CONNECT_TIMEOUT_S,
        help=f"seconds to wait for each arm controller to answer when connecting, in (0, "
        f"{MAX_CONNECT_TIMEOUT_S:g}] (--backend trossen and wire; default "
        f"{CONNECT_TIMEOUT_S:g}, the driver's)",
    )
    p.add_argument("--dry_run", action="store_true", help="validate and report only; nothing moves")
    p.add_argument("--no_progress", action="store_true", help="no progress bar")
    return p


def main(
    argv: Sequence[str] | None = None,
    *,
    driver_factory: DriverFactory | None = None,
    clock: Clock | None = None,
    on_served: Callable[[Any], None] | None = None,
) -> int:
    """Validate, then replay; returns the exit status.

    ``driver_factory`` (default :func:`make_drivers`) and ``clock`` are for tests and
    embedding: ``driver_factory(backend, clock) -> (drivers, clock)``. ``on_served`` is
    called with the served kit (``twin.served_kit.ServedKit``) of ``--backend wire`` once it
    serves, before any arm is configured (tests change its arms' limits there).

    Stop signals are handled from start to end (:mod:`trossen_arm_mujoco.real.stop`):
    before any arm may move one raises :class:`~trossen_arm_mujoco.real.stop.Interrupted`
    (:func:`cli` turns it into one line); from then on it stops the replay cleanly, and
    once streaming is over it is only noted, so the results are always written whole.
    """
    flag = StopFlag(armed=False)
    with stop_on_signals(flag):
        return _run(build_parser().parse_args(argv), driver_factory, clock, flag, on_served)


def _ips(args: argparse.Namespace) -> dict[str, str]:
    """The arms' addresses: the flags, else the backend's defaults; checked before anything
    connects (IPv4, one per arm; loopback for wire), a one-line error naming the flag."""
    wire = args.backend == "wire"
    default = (
        {"left": "127.0.0.2", "right": "127.0.0.3"}
        if wire
        else {"left": "192.168.1.5", "right": "192.168.1.4"}
    )
    given = {"left": args.left_ip, "right": args.right_ip}
    ips = {side: default[side] if given[side] is None else given[side] for side in given}
    if not wire:
        return check_arm_ips(ips, IP_FLAGS)
    from trossen_arm_mujoco.twin.served_kit import check_kit_ips
    from trossen_arm_mujoco.twin.serving import require_sim_server

    ips = check_kit_ips(ips, IP_FLAGS)
    if not args.dry_run:
        require_sim_server()
    return ips


def _run(
    args: argparse.Namespace,
    driver_factory: DriverFactory | None,
    clock: Clock | None,
    flag: StopFlag,
    on_served: Callable[[Any], None] | None = None,
) -> int:
    check_fps(args.fps)
    if not (math.isfinite(args.goal_time_factor) and 0 < args.goal_time_factor <= 20):
        raise UserError(f"--goal_time_factor must be in (0, 20], got {args.goal_time_factor:g}")
    limits = ArmLimits.from_mjcf()
    top = float(limits.driver_upper[-1])
    if not (math.isfinite(args.gripper_max) and 0 < args.gripper_max <= top):
        raise UserError(f"--gripper_max must be in (0, {top:g}] m, got {args.gripper_max:g}")
    timeout = args.connect_timeout
    if not (math.isfinite(timeout) and 0 < timeout <= MAX_CONNECT_TIMEOUT_S):
        raise UserError(
            f"--connect_timeout must be in (0, {MAX_CONNECT_TIMEOUT_S:g}] s, got {timeout:g}"
        )
    if args.episode_idx < 0:
        raise UserError(f"--episode_idx must be >= 0, got {args.episode_idx}")
    if args.output_dir is not None and not str(args.output_dir).strip():
        raise UserError(
            "--output_dir must not be empty; give a folder, or leave the flag out to write "
            "next to the episode (<data folder>/replay)"
        )
    ips = _ips(args)
    ee_note = _check_end_effector(args.end_effector, args.backend, args.dry_run)
    folder = resolve_data_dir(args.root_dir, args.data_dir)
    episode = load_episode(_find_episode(folder, args.episode_idx))
    if str(episode.attrs.get("layout", "")) == "mobileai":  # before any driver exists
        raise UserError(
            f"{episode.path} is a Mobile AI recording (layout mobileai: the arms' 14 values, "
            "then the base's x.vel, theta.vel); replay-real drives the Stationary AI kit's two "
            "arms and has no base driver: replay Stationary AI recordings only"
        )
    dt = recorded_dt(episode)
    trajectory = validate_actions(episode.action, args.fps, limits)
    gripper = clamp_gripper(trajectory.commands, args.gripper_max)[1]
    speed = dt * args.fps  # replay speed relative to the recording
    pace = "the recorded speed" if abs(speed - 1) < 1e-9 else f"{speed:.3g}x the recorded speed"
    print(
        f"{episode.path}: {trajectory.num_steps} steps, {trajectory.num_steps / args.fps:.1f} s "
        f"at --fps {args.fps:g} ({pace}, recorded at {1.0 / dt:g} Hz), "
        f"goal time {args.goal_time_factor / args.fps:.3g} s per command"
    )
    print(gripper.describe())
    if ee_note:
        print(ee_note)
    if args.dry_run:
        print(format_trajectory_report(trajectory, limits))
        print("dry run: trajectory is valid; no driver was created and nothing moved")
        return 0

    stem = f"episode_{args.episode_idx}_{args.backend}"
    out_dir = check_outputs(_output_dir(args, episode), stem, "--output_dir")
    factory = (
        driver_factory
        if driver_factory is not None
        else functools.partial(make_drivers, connect_timeout=args.connect_timeout)
    )
    if clock is None and args.backend == "sim" and args.realtime:
        clock = SimClock(realtime=True)
    config = ReplayConfig(
        fps=args.fps,
        goal_time_factor=args.goal_time_factor,
        ips=ips,
        model=DEFAULT_MODEL,
        # the in-process twin models one gripper: it is configured with its default preset
        end_effector=args.end_effector if args.backend != "sim" else DEFAULT_END_EFFECTOR,
        gripper_max=args.gripper_max,
        progress=not args.no_progress,
    )
    kit = _start_kit(episode, ips, on_served) if args.backend == "wire" else None
    try:
        drivers, run_clock = factory(args.backend, clock)
        # from here on a signal never raises: it stops streaming, or (once streaming is
        # over, flag closed) is only noted, so the arms always go home and the results
        # are whole
        result = replay(trajectory, drivers, run_clock, config, limits, flag=flag)
    finally:
        served = _stop_kit(kit)

    summary = {
        "episode": str(episode.path),
        "backend": args.backend,
        "fps": args.fps,
        "goal_time_s": config.goal_time,
        "recorded_dt_s": dt,
        "steps_total": result.steps_total,
        "steps_done": result.steps_done,
        "status": result.status,
        "reason": result.reason,
        "late_steps": result.late_steps,
        "clipped_values": trajectory.clipped,
        "max_clip": trajectory.max_clip,
        **(result.gripper or gripper).as_dict(),
        "end_effector": args.end_effector,
        "trossen_arm_version": installed_version() if find_trossen_arm() else None,
        "measured_at": "end of each command period, just before the next command",
        "arms_home_and_asleep": bool(result.configured) and result.arms_safe,
        "late_signals": result.late_signals,
        "final_positions": {k: v.tolist() for k, v in result.final_positions.items()},
        "recovered": result.recovered,
        **({"served": served} if served is not None else {}),
    }
    try:
        paths = write_outputs(out_dir, stem, result.log, summary)
    except OSError as exc:
        also = f"; {result.reason}" if result.reason else ""
        _say_safe(result)
        return report_error(
            f"cannot write the replay results to {out_dir}: {describe_os_error(exc)} "
            f"({os_error_hint(exc, '--output_dir')}){also}",
            result.exit_code or 1,
        )
    if result.steps_done:
        print(f"tracking error (measured - commanded) over {result.steps_done} steps:")
        print(format_error_table(result.log.errors()))
    written = ", ".join(str(p) for p in paths.values() if p is not None)
    print(f"wrote {written}")
    if paths["plot"] is None and result.steps_done:
        print(f"note: no plot: matplotlib is not installed ({PLOT_HINT})")
    if flag.late:
        names = ", ".join(dict.fromkeys(flag.late))
        print(
            f"note: {names} arrived after streaming had ended; noted and ignored: the arms "
            f"finished their home/sleep moves and the results were written in full"
        )
    if result.exit_code:
        _say_safe(result)
        return report_error(result.reason, result.exit_code)
    clamped = (result.gripper or gripper).count
    print(
        f"replay completed: {result.steps_done} steps, {clamped} gripper command(s) clamped "
        f"to {args.gripper_max:g} m; arms are home and asleep"
    )
    return 0


def _find_episode(folder: Path, index: int) -> Path:
    """The file of episode ``index`` in ``folder``; a missing one is a one-line error that
    names the flags choosing it and the episodes that are there."""
    path = episode_path(folder, index)
    if path.is_file():
        return path
    if not folder.is_dir():
        raise UserError(
            f"data folder not found: {folder}; check --data_dir (relative to --root_dir "
            f"unless absolute)"
        )
    found = [k for k, _ in list_episodes(folder)]
    if not found:
        raise UserError(f"{folder} holds no episode files (episode_<k>.hdf5); check --data_dir")
    raise UserError(
        f"episode file not found: {path}; {folder} holds {format_indices(found)}: pass one "
        f"of them with --episode_idx"
    )


def _output_dir(args: argparse.Namespace, episode: Episode) -> Path:
    """``--output_dir`` (``~`` expanded), else ``replay/`` next to the episode."""
    if args.output_dir is None:
        return episode.path.parent / "replay"
    return Path(args.output_dir).expanduser()


def _start_kit(episode: Episode, ips: dict[str, str], on_served: Callable[[Any], None] | None):
    """``--backend wire``: serve the simulated kit on ``ips``, set up like the episode's
    scene (its task, the objects at its recorded start); faults are reported on stdout."""
    from trossen_arm_mujoco.twin.served_kit import kit_for_episode

    kit = kit_for_episode(episode.attrs, ips, say=_say_line)
    try:
        kit.start()
        print(
            f"serving the simulated kit ({kit.world.task_name}) on {ips['left']} (left) and "
            f"{ips['right']} (right) for the real trossen_arm driver",
            flush=True,
        )
        if on_served is not None:
            on_served(kit)
    except BaseException:
        kit.close()
        raise
    return kit


def _stop_kit(kit) -> dict[str, Any] | None:
    """Stop a served kit; what the summary says about it (None without one)."""
    if kit is None:
        return None
    kit.close()
    return {
        "task_name": kit.world.task_name,
        "ips": kit.ips,
        "realtime_factor": kit.world.realtime_factor,
        "faults": list(kit.faults),
    }


def _say_line(text: str) -> None:
    try:
        print(text, flush=True)
    except (OSError, ValueError):
        pass


def _say_safe(result: ReplayResult) -> None:
    """After a stop: say on stdout where the arms are (stderr keeps the one error line)."""
    if not result.arms_safe:
        return  # the error line lists the shutdown errors
    done = f"replay stopped after {result.steps_done}/{result.steps_total} steps"
    if result.configured:
        print(f"{done}; arms are home and asleep", flush=True)
    else:
        print(f"{done}; no arm was configured, none moved", flush=True)


def _check_end_effector(name: str, backend: str, dry_run: bool) -> str | None:
    """Check ``--end_effector`` against the installed trossen_arm; returns a note or None.

    Raises:
        UserError: an unknown preset (listing the valid ones), or the trossen backend
            without trossen_arm (install hint).
    """
    ta = find_trossen_arm()
    if ta is None:
        if backend in ("trossen", "wire") and not dry_run:
            import_trossen_arm()  # raises the install hint
        return f"note: trossen_arm is not installed, so --end_effector {name} is not checked"
    check_end_effector(ta, name)
    if backend == "sim" and name != DEFAULT_END_EFFECTOR:
        return f"note: --end_effector {name} is valid; the twin models the follower gripper"
    return None


def cli(
    argv: Sequence[str] | None = None,
    *,
    driver_factory: DriverFactory | None = None,
    clock: Clock | None = None,
    on_served: Callable[[Any], None] | None = None,
) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2.

    A stop signal before any arm was configured is one line too, with exit status
    128 + its number.
    """

    def guarded(args: Sequence[str] | None) -> int:
        try:
            return main(args, driver_factory=driver_factory, clock=clock, on_served=on_served)
        except Interrupted as exc:
            return report_error(
                f"{exc} before any arm was configured; nothing moved", exc.exit_code
            )

    try:
        return run_cli(guarded, argv)
    finally:
        # drivers and the driver's Python log backend go before the interpreter does (the
        # backend left installed ends the process with SIGSEGV at exit); atexit does it too
        release_driver_logs()


if __name__ == "__main__":
    sys.exit(cli())
