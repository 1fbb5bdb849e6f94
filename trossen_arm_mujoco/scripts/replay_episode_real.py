"""Replay a recorded episode on two real arms, or on their simulated twin (also
``trossen-mujoco replay-real``).

The trajectory is validated first (shape, finite values, joint limits, joint speeds at
``--fps`` in [0.5, 1000] Hz; a violation is one line, exit 2, before any driver exists);
grippers above ``--gripper_max`` (0.04 m) are clamped. The arms (``--backend sim``: the twin;
``wire``: the real driver against the served kit; else ``--left_ip`` / ``--right_ip``) move
to the first action over 2 s, follow the actions at ``--fps``, then go home and to sleep; an
error or a stop signal stops streaming within 0.05 s and still homes every configured arm
(exit 128 + the signal's number after a signal). Tracking results go to
``<data folder>/replay/``, always complete; ``--dry_run`` moves nothing.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

__all__ = ["build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import functools
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.constants import ROOT_DIR
from trossen_arm_mujoco.data.reader import (
    Episode,
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
    find_trossen_arm,
    installed_version,
    release_driver_logs,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX, clamp_gripper
from trossen_arm_mujoco.real.preflight import recorded_dt
from trossen_arm_mujoco.real.replay import (
    BACKENDS,
    MAX_FPS,
    MIN_FPS,
    DriverFactory,
    ReplayConfig,
    ReplayResult,
    make_drivers,
    replay,
)
from trossen_arm_mujoco.real.report import (
    PLOT_HINT,
    check_outputs,
    format_error_table,
    write_outputs,
)
from trossen_arm_mujoco.real.validate import format_trajectory_report, validate_actions
from trossen_arm_mujoco.scripts.replay_real_checks import (
    MAX_CONNECT_TIMEOUT_S,
    arm_ips,
    check_numbers,
    end_effector_note,
    find_episode,
    output_dir,
)
from trossen_arm_mujoco.stopping import RAISE, StopSignals, interrupt_signal, signal_name


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
    """Validate, then replay.

    Stop signals are handled from start to end (a ``stopping.StopSignals``): before any arm
    may move one ends the command at once (one ``error:`` line, exit status 128 + its
    number); from then on it stops the replay cleanly, and once streaming is over it is
    only noted, so the results are always written whole.

    Args:
        argv: the command line (None: ``sys.argv[1:]``).
        driver_factory: ``driver_factory(backend, clock) -> (drivers, clock)``; None:
            :func:`make_drivers` (for tests and embedding).
        clock: the clock to wait on; None: the backend's.
        on_served: called with the served kit (``twin.served_kit.ServedKit``) of
            ``--backend wire`` once it serves, before any arm is configured (tests change
            its arms' limits there).

    Returns:
        The exit status.
    """
    stops = StopSignals(RAISE)  # nothing may move yet: a stop signal ends the command
    try:
        with stops.handling():
            return _run(build_parser().parse_args(argv), driver_factory, clock, stops, on_served)
    except KeyboardInterrupt as exc:
        if stops.mode != RAISE:  # not ours: replay() handles every signal from its start
            raise
        signum = interrupt_signal(exc, stops)
        return report_error(
            f"interrupted by {signal_name(signum)} before any arm was configured; nothing moved",
            128 + signum,
        )


def _run(
    args: argparse.Namespace,
    driver_factory: DriverFactory | None,
    clock: Clock | None,
    stops: StopSignals,
    on_served: Callable[[Any], None] | None = None,
) -> int:
    limits = check_numbers(args)
    ips = arm_ips(args)
    ee_note = end_effector_note(args.end_effector, args.backend, args.dry_run)
    folder = resolve_data_dir(args.root_dir, args.data_dir)
    episode = load_episode(find_episode(folder, args.episode_idx))
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
    out_dir = check_outputs(output_dir(args, episode), stem, "--output_dir")
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
        # over) is only noted, so the arms always go home and the results are whole
        result = replay(trajectory, drivers, run_clock, config, limits, stops=stops)
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
    if stops.late:  # also those while the results were written
        names = ", ".join(dict.fromkeys(signal_name(s) for s in stops.late))
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


def cli(
    argv: Sequence[str] | None = None,
    *,
    driver_factory: DriverFactory | None = None,
    clock: Clock | None = None,
    on_served: Callable[[Any], None] | None = None,
) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2.

    Args:
        argv: as for :func:`main`.
        driver_factory: as for :func:`main`.
        clock: as for :func:`main`.
        on_served: as for :func:`main`.
    """
    command = functools.partial(
        main, driver_factory=driver_factory, clock=clock, on_served=on_served
    )
    try:
        return run_cli(command, argv)
    finally:
        # drivers and the driver's Python log backend go before the interpreter does (the
        # backend left installed ends the process with SIGSEGV at exit); atexit does it too
        release_driver_logs()


if __name__ == "__main__":
    sys.exit(cli())
