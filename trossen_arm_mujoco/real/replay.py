"""Rate-limited replay of a validated trajectory on two arms, with a safe exit.

:func:`replay`, for the arms ``left`` and ``right``: clamps the gripper commands to
``gripper_max``; configures each arm (position mode); moves to the first command over
``start_time`` and waits ``settle_time``; streams the commands at ``fps`` (per step
``set_all_positions(cmd, goal_time_factor / fps, blocking=False)``, waits until
``t0 + (k + 1) / fps``, logs commanded vs measured); and always, after any exception or a
stop signal, recovers an arm in error where it can, moves every configured arm home and to
sleep, and cleans up (:func:`.shutdown.shutdown`). Stop signals (main thread only) are
recorded as stop requests (a ``stopping.StopSignals``) checked every :data:`WAIT_SLICE` s;
once streaming ends they are only noted. All waiting goes through a ``Clock`` (real or
simulated time). ``fps`` is bounded by :func:`check_fps` (a command lasts 1 ms ..
:data:`MAX_COMMAND_PERIOD`).

Docs: docs/cli/replay-real.md; the sequence in full: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
import signal
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.real.clock import Clock, SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    CONNECT_TIMEOUT_S,
    DEFAULT_END_EFFECTOR,
    DEFAULT_MODEL,
    ArmDriver,
    TrossenArmDriver,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX, GripperClamp, clamp_gripper
from trossen_arm_mujoco.real.report import TrackingLog
from trossen_arm_mujoco.real.shutdown import (
    ArmStates,
    DriverError,
    call,
    one_line,
    read_positions,
    shutdown,
)
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.real.validate import ARMS, ArmLimits, Trajectory, safe_move_time
from trossen_arm_mujoco.stopping import NOTE, REQUEST, StopSignals, signal_name

__all__ = [
    "BACKENDS",
    "MAX_COMMAND_PERIOD",
    "MAX_FPS",
    "MIN_FPS",
    "DriverFactory",
    "ReplayConfig",
    "ReplayResult",
    "WAIT_SLICE",
    "check_fps",
    "make_drivers",
    "replay",
]

#: ``trossen``: real arms through ``trossen_arm``; ``sim``: the in-process MuJoCo twin
#: (``SimArmDriver``, simulated time); ``wire``: the real ``trossen_arm`` driver against the
#: served kit (``trossen_arm_mujoco.twin``) on loopback addresses, in real time; its caller
#: starts the served kit.
BACKENDS: tuple[str, ...] = ("trossen", "sim", "wire")

#: Longest time one streamed command may last (s), i.e. ``1 / MIN_FPS``: the goal time
#: ``trossen_arm`` gives a whole move by default (``set_all_positions(goal_time=2.0)``),
#: as do this replay's start and home moves. A slower "stream" is a series of separate
#: moves, and at absurd rates (``--fps 1e-9``) one command would last for years.
MAX_COMMAND_PERIOD: float = 2.0
#: Lowest command rate (Hz).
MIN_FPS: float = 1.0 / MAX_COMMAND_PERIOD
#: Highest command rate (Hz): one command per millisecond.
MAX_FPS: float = 1000.0
#: Longest single wait (s) between two checks for a stop.
WAIT_SLICE: float = 0.05


def check_fps(fps: float, flag: str = "--fps") -> None:
    """Raise a one-line :class:`UserError` unless ``MIN_FPS <= fps <= MAX_FPS``.

    The line states the bounds and why: one command lasts ``1 / fps``, which must lie
    between 1 ms and :data:`MAX_COMMAND_PERIOD`.
    """
    if math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS:
        return
    why = (
        f"one command lasts 1/fps, which must be between 1 ms and {MAX_COMMAND_PERIOD:g} s, "
        f"the goal time trossen_arm gives a whole move by default (as do this replay's start "
        f"and home moves)"
    )
    if math.isfinite(fps) and 0 < fps < MIN_FPS:
        why = f"one command would last {1.0 / fps:.3g} s; {why}"
    raise UserError(f"{flag} must be in [{MIN_FPS:g}, {MAX_FPS:g}] Hz, got {fps:g}: {why}")


#: Builds the two drivers of a backend: ``(backend, clock or None) -> (drivers, clock)``.
DriverFactory = Callable[[str, "Clock | None"], "tuple[dict[str, ArmDriver], Clock]"]


def make_drivers(
    backend: str, clock: Clock | None = None, connect_timeout: float = CONNECT_TIMEOUT_S
) -> tuple[dict[str, ArmDriver], Clock]:
    """The two drivers of ``backend`` and the clock to wait on.

    ``"sim"``: two :class:`SimArmDriver` sharing one :class:`SimClock` (``clock`` if given,
    which must then be a SimClock). ``"trossen"`` and ``"wire"``: two
    :class:`TrossenArmDriver` (no network until configure) and a :class:`WallClock` unless
    ``clock`` is given; for ``"wire"`` the caller serves the kit on the addresses replay
    configures (``scripts/replay_episode_real.py`` does).

    Args:
        backend: ``"sim"``, ``"trossen"`` or ``"wire"``.
        clock: the clock to wait on; None: a new one of the backend's kind.
        connect_timeout: seconds ``configure`` waits at most for a controller.
    """
    if backend == "sim":
        clock = SimClock() if clock is None else clock
        if not isinstance(clock, SimClock):
            raise TypeError("the sim backend needs a SimClock")
        return {side: SimArmDriver(clock) for side in ARMS}, clock
    if backend in ("trossen", "wire"):
        drivers: dict[str, ArmDriver] = {side: TrossenArmDriver(connect_timeout) for side in ARMS}
        return drivers, WallClock() if clock is None else clock
    raise unknown_name_error("backend", backend, BACKENDS)


@dataclass
class ReplayConfig:
    """How to replay. Times in s, rates in Hz."""

    fps: float = 10.0
    goal_time_factor: float = 3.0
    ips: dict[str, str] = field(
        default_factory=lambda: {"left": "192.168.1.5", "right": "192.168.1.4"}
    )
    model: str = DEFAULT_MODEL
    end_effector: str = DEFAULT_END_EFFECTOR
    start_time: float = 2.0
    home_time: float = 2.0
    sleep_time: float = 2.0
    settle_time: float = 0.5
    gripper_max: float = GRIPPER_MAX
    progress: bool = True

    @property
    def goal_time(self) -> float:
        """Goal time of each streamed command (s)."""
        return self.goal_time_factor / self.fps


@dataclass
class ReplayResult:
    """Outcome of :func:`replay`.

    Attributes:
        log: commanded vs measured positions of the streamed steps.
        steps_total: steps in the trajectory.
        status: ``"completed"``, ``"interrupted"`` or ``"failed"``.
        reason: one line saying why replay stopped early, None when completed.
        exit_code: 0, 128 + signal number, or 1 for errors.
        final_positions: ``{arm: (7,)}`` measured after the sleep move (rad, m).
        late_steps: steps whose measurement came over half a period late.
        gripper: the gripper commands clamped to ``config.gripper_max``.
        configured: arms whose ``configure`` returned (the arms that could move).
        shutdown_errors: one line per failed call of the home/sleep/cleanup exit.
        late_signals: stop signals (names) received after streaming had ended, while
            the arms went home; they change nothing (the exit ran to its end).
        recovered: one line per arm whose controller error state was cleared to take it
            home (``recover()``), e.g. after a joint limit was exceeded.
    """

    log: TrackingLog
    steps_total: int
    status: str = "completed"
    reason: str | None = None
    exit_code: int = 0
    final_positions: dict[str, np.ndarray] = field(default_factory=dict)
    late_steps: int = 0
    gripper: GripperClamp | None = None
    configured: list[str] = field(default_factory=list)
    shutdown_errors: list[str] = field(default_factory=list)
    late_signals: list[str] = field(default_factory=list)
    recovered: list[str] = field(default_factory=list)

    @property
    def steps_done(self) -> int:
        """Steps streamed and logged."""
        return len(self.log)

    @property
    def arms_safe(self) -> bool:
        """Every configured arm went home and to sleep and was cleaned up, without error."""
        return not self.shutdown_errors


def wait(clock: Clock, seconds: float, stops: StopSignals, chunk: float = WAIT_SLICE) -> None:
    """Wait ``seconds`` (s) in slices of at most ``chunk``, returning early once a stop is
    requested.

    A signal handler runs between two slices at the latest, and records the request: however
    long the wait, a stop takes effect within ``chunk`` (plus the time one slice takes to
    simulate, on the twin).
    """
    end = clock.now() + seconds
    while not stops.requested and (left := end - clock.now()) > 1e-9:
        clock.sleep(min(chunk, left))


def _why(stops: StopSignals) -> str:
    """The first stop in words: ``interrupted by SIGTERM``, or the error."""
    return f"interrupted by {stops.reason}" if stops.by_signal else stops.reason


def _say(text: str) -> None:
    """Print ``text`` to stdout; a closed stdout (SIGHUP) must not stop the safe exit."""
    try:
        print(text, flush=True)
    except (OSError, ValueError):
        pass


def _move_to_start(
    drivers: Mapping[str, ArmDriver], goals: np.ndarray, minimum: float, limits: ArmLimits
) -> float:
    """Send both arms to their first commands without blocking; returns the goal time (s)."""
    current = [read_positions(s, drivers[s]) for s in ARMS]
    goal_time = max(safe_move_time(c, g, minimum, limits) for c, g in zip(current, goals))
    for side, goal in zip(ARMS, goals, strict=True):
        call(
            side,
            "set_all_positions (start)",
            drivers[side].set_all_positions,
            goal,
            goal_time,
            False,
        )
    return goal_time


def _stream(
    commands: np.ndarray,
    drivers: Mapping[str, ArmDriver],
    clock: Clock,
    config: ReplayConfig,
    limits: ArmLimits,
    stops: StopSignals,
    states: ArmStates,
    result: ReplayResult,
) -> None:
    for side in ARMS:
        if stops.requested:
            return
        drv = drivers[side]
        args = (config.ips[side], config.model, config.end_effector, True)
        states.attempted.append(side)
        call(side, f"configure ({config.ips[side]})", drv.configure, *args)
        states.configured.append(side)
        call(side, "set_all_modes_position", drv.set_all_modes_position)
        states.position_mode.append(side)
    if stops.requested:
        return
    wait(clock, _move_to_start(drivers, commands[0], config.start_time, limits), stops)
    wait(clock, config.settle_time, stops)
    period, goal_time = 1.0 / config.fps, config.goal_time
    bar = tqdm(
        total=len(commands),
        desc="replay",
        unit="step",
        file=sys.stderr,
        disable=not config.progress,
        leave=False,
    )
    with bar:
        t0 = clock.now()
        for k, cmd in enumerate(commands):
            if stops.requested:
                return
            for a, side in enumerate(ARMS):
                send = drivers[side].set_all_positions
                call(side, f"set_all_positions (step {k})", send, cmd[a], goal_time, False)
            deadline = t0 + (k + 1) * period
            wait(clock, deadline - clock.now(), stops)
            if (
                stops.requested
            ):  # stopped within the period: its measurement would be early, not logged
                return
            if clock.now() > deadline + 0.5 * period:
                result.late_steps += 1
            meas = [read_positions(s, drivers[s]) for s in ARMS]
            result.log.add(clock.now() - t0, cmd, np.stack(meas))
            bar.update(1)


def _recover(
    drivers: Mapping[str, ArmDriver], states: ArmStates, result: ReplayResult
) -> list[str]:
    """Before the safe exit: clear a command-caused controller error state of every
    configured arm whose driver has ``recover()`` (``TrossenArmDriver``), so that it can
    go home. Reports each on stdout; returns one line per arm that could not be recovered
    (its home move then fails and is reported too)."""
    errors: list[str] = []
    for side in states.configured:
        recover = getattr(drivers[side], "recover", None)
        if recover is None:
            continue
        try:
            done = call(side, "recover", recover)
        except (DriverError, KeyboardInterrupt) as exc:
            errors.append(
                one_line(exc)
                if isinstance(exc, DriverError)
                else f"{side} arm: recover failed: {one_line(exc)}"
            )
            continue
        if done:
            line = f"{side} arm: {done}"
            result.recovered.append(line)
            _say(f"{line}; taking it home")
    return errors


def replay(
    trajectory: Trajectory,
    drivers: Mapping[str, ArmDriver],
    clock: Clock,
    config: ReplayConfig | None = None,
    limits: ArmLimits | None = None,
    stops: StopSignals | None = None,
) -> ReplayResult:
    """Replay ``trajectory`` on ``drivers`` (``{"left", "right"}``); see the module doc.

    Never raises for driver errors (of any exception type) or signals: the outcome is in
    the result, after the arms went home and to sleep. The ``stopping: ...`` notice goes
    to stdout, so that stderr holds only the caller's one-line error.

    Args:
        stops: the caller's stop signals (mode ``REQUEST`` here, ``NOTE`` once streaming
            ends), so that the caller keeps handling signals the same way after replay
            (while it writes the results); fresh ones when None.
    """
    config = config if config is not None else ReplayConfig(fps=trajectory.fps)
    limits = limits if limits is not None else ArmLimits.from_mjcf()
    result = ReplayResult(log=TrackingLog(), steps_total=trajectory.num_steps)
    commands, result.gripper = clamp_gripper(trajectory.commands, config.gripper_max, ARMS)
    stops, states = stops if stops is not None else StopSignals(), ArmStates()
    with stops.handling():
        stops.mode = REQUEST  # an arm may move from here on: a signal stops streaming
        try:
            _stream(commands, drivers, clock, config, limits, stops, states, result)
        except KeyboardInterrupt:
            stops.request("interrupted by SIGINT (KeyboardInterrupt)", 128 + signal.SIGINT)
        except Exception as exc:
            stops.request(one_line(exc), 1)
        finally:
            stops.mode = NOTE  # from here on a signal is only noted: the exit runs to its end
            if stops.requested:
                _say(
                    f"stopping: {_why(stops)}; moving the arms home, then to sleep "
                    "(further signals are noted but ignored until they are asleep; only "
                    "SIGKILL ends this at once, leaving the arms where they are)"
                    if states.configured
                    else f"stopping: {_why(stops)}; no arm was configured, none moved"
                )
            recover_errors = _recover(drivers, states, result)
            result.final_positions, shutdown_errors = shutdown(
                drivers,
                states,
                clock,
                config.home_time,
                config.sleep_time,
                config.settle_time,
                limits,
            )
            shutdown_errors = recover_errors + shutdown_errors
    result.configured, result.shutdown_errors = list(states.configured), shutdown_errors
    result.late_signals = [signal_name(s) for s in stops.late]
    at = f"at step {result.steps_done}/{result.steps_total}"
    if stops.requested:
        result.status = "failed" if stops.exit_code == 1 else "interrupted"
        result.reason, result.exit_code = f"replay stopped {at}: {_why(stops)}", stops.exit_code
    if shutdown_errors:
        head = result.reason or f"replay streamed {result.steps_done}/{result.steps_total} steps"
        result.reason = f"{head}; shutdown errors: {'; '.join(shutdown_errors)}"
        result.status, result.exit_code = "failed", result.exit_code or 1
    return result
