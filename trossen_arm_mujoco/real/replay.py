"""Rate-limited replay of a validated trajectory on two arms, with a safe exit.

:func:`replay` runs, for the two arms ``left`` and ``right``:

1. ``configure`` each arm (model, end-effector preset, address), position mode;
2. move to the first command, over ``start_time`` (2 s; longer if the speed limits
   need it), and wait ``settle_time``;
3. stream the commands at ``fps``: per step, ``set_all_positions(cmd, goal_time,
   blocking=False)`` to both arms with ``goal_time = goal_time_factor / fps``, wait
   until the step's deadline (``t0 + (k + 1) / fps``, so waits do not drift), then read
   both arms' positions and log commanded vs measured;
4. always, also after an error, SIGINT or SIGTERM: stop streaming, move every
   configured arm home (``driver.HOME_POSE``), then to the sleep pose (all joints 0),
   then ``cleanup``.

SIGINT and SIGTERM are caught while replay runs (main thread only) and only set a stop
flag, checked before every step; the previous handlers are restored afterwards. The
home and sleep moves are not interruptible. All waiting goes through a
:class:`~trossen_arm_mujoco.real.clock.Clock`: real time for real arms, simulated time
(much faster) for the twin.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.real.clock import Clock, SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    DEFAULT_END_EFFECTOR,
    DEFAULT_MODEL,
    HOME_POSE,
    SLEEP_POSE,
    ArmDriver,
    TrossenArmDriver,
)
from trossen_arm_mujoco.real.report import TrackingLog
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.real.stop import StopFlag, stop_on_signals
from trossen_arm_mujoco.real.validate import ARMS, ArmLimits, Trajectory, safe_move_time

BACKENDS: tuple[str, ...] = ("trossen", "sim")

#: Builds the two drivers of a backend: ``(backend, clock or None) -> (drivers, clock)``.
DriverFactory = Callable[[str, "Clock | None"], "tuple[dict[str, ArmDriver], Clock]"]


def make_drivers(backend: str, clock: Clock | None = None) -> tuple[dict[str, ArmDriver], Clock]:
    """The two drivers of ``backend`` and the clock to wait on.

    ``"sim"``: two :class:`SimArmDriver` sharing one :class:`SimClock` (``clock`` if given,
    which must then be a SimClock). ``"trossen"``: two :class:`TrossenArmDriver` (no
    network until configure) and a :class:`WallClock` unless ``clock`` is given.
    """
    if backend == "sim":
        clock = SimClock() if clock is None else clock
        if not isinstance(clock, SimClock):
            raise TypeError("the sim backend needs a SimClock")
        return {side: SimArmDriver(clock) for side in ARMS}, clock
    if backend == "trossen":
        drivers: dict[str, ArmDriver] = {side: TrossenArmDriver() for side in ARMS}
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
    """

    log: TrackingLog
    steps_total: int
    status: str = "completed"
    reason: str | None = None
    exit_code: int = 0
    final_positions: dict[str, np.ndarray] = field(default_factory=dict)
    late_steps: int = 0

    @property
    def steps_done(self) -> int:
        """Steps streamed and logged."""
        return len(self.log)


class DriverError(RuntimeError):
    """A driver call failed; the message names the arm and the call."""


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _call(side: str, what: str, fn: Callable[..., Any], *args: Any) -> Any:
    try:
        return fn(*args)
    except Exception as exc:
        raise DriverError(f"{side} arm: {what} failed: {_one_line(exc)}") from exc


def _wait(clock: Clock, seconds: float, flag: StopFlag, chunk: float = 0.1) -> None:
    """Wait ``seconds`` (s) in chunks, returning early once ``flag`` is set."""
    end = clock.now() + seconds
    while not flag and (left := end - clock.now()) > 1e-9:
        clock.sleep(min(chunk, left))


def _move(
    drivers: Mapping[str, ArmDriver],
    sides: list[str],
    goals: Mapping[str, np.ndarray],
    minimum: float,
    limits: ArmLimits,
) -> float:
    """Send each arm in ``sides`` to its goal without blocking; returns the goal time (s)."""
    current = {s: _call(s, "get_all_positions", drivers[s].get_all_positions) for s in sides}
    goal_time = max(safe_move_time(current[s], goals[s], minimum, limits) for s in sides)
    for s in sides:
        _call(s, "set_all_positions", drivers[s].set_all_positions, goals[s], goal_time, False)
    return goal_time


def _stream(
    trajectory: Trajectory,
    drivers: Mapping[str, ArmDriver],
    clock: Clock,
    config: ReplayConfig,
    limits: ArmLimits,
    flag: StopFlag,
    configured: list[str],
    result: ReplayResult,
) -> None:
    for side in ARMS:
        drv = drivers[side]
        args = (config.ips[side], config.model, config.end_effector, True)
        _call(side, f"configure ({config.ips[side]})", drv.configure, *args)
        configured.append(side)
        _call(side, "set_all_modes_position", drv.set_all_modes_position)
    if flag:
        return
    first = dict(zip(ARMS, trajectory.commands[0], strict=True))
    _wait(clock, _move(drivers, list(ARMS), first, config.start_time, limits), flag)
    _wait(clock, config.settle_time, flag)
    period, goal_time = 1.0 / config.fps, config.goal_time
    bar = tqdm(
        total=trajectory.num_steps, desc="replay", unit="step", file=sys.stderr,
        disable=not config.progress, leave=False,
    )  # fmt: skip
    with bar:
        t0 = clock.now()
        for k, cmd in enumerate(trajectory.commands):
            if flag:
                return
            for a, side in enumerate(ARMS):
                send = drivers[side].set_all_positions
                _call(side, f"set_all_positions (step {k})", send, cmd[a], goal_time, False)
            deadline = t0 + (k + 1) * period
            clock.sleep(deadline - clock.now())
            if clock.now() > deadline + 0.5 * period:
                result.late_steps += 1
            meas = [_call(s, "get_all_positions", drivers[s].get_all_positions) for s in ARMS]
            result.log.add(clock.now() - t0, cmd, np.stack(meas))
            bar.update(1)


def _shutdown(
    drivers: Mapping[str, ArmDriver],
    configured: list[str],
    clock: Clock,
    config: ReplayConfig,
    limits: ArmLimits,
    result: ReplayResult,
) -> list[str]:
    """Home, sleep, cleanup every configured arm; each call is tried. Returns the errors."""
    errors: list[str] = []
    for pose, minimum in ((HOME_POSE, config.home_time), (SLEEP_POSE, config.sleep_time)):
        goal_times = []
        for side in configured:
            try:
                goal = {side: np.asarray(pose)}
                goal_times.append(_move(drivers, [side], goal, minimum, limits))
            except DriverError as exc:
                errors.append(str(exc))
        if goal_times:
            clock.sleep(max(goal_times) + config.settle_time)
    for side in configured:
        try:
            result.final_positions[side] = _call(
                side, "get_all_positions", drivers[side].get_all_positions
            )
        except DriverError as exc:
            errors.append(str(exc))
        try:
            _call(side, "cleanup", drivers[side].cleanup)
        except DriverError as exc:
            errors.append(str(exc))
    return errors


def replay(
    trajectory: Trajectory,
    drivers: Mapping[str, ArmDriver],
    clock: Clock,
    config: ReplayConfig | None = None,
    limits: ArmLimits | None = None,
) -> ReplayResult:
    """Replay ``trajectory`` on ``drivers`` (``{"left", "right"}``); see the module doc.

    Never raises for driver errors or signals: the outcome is in the result, after the
    arms went home and to sleep.
    """
    config = config if config is not None else ReplayConfig(fps=trajectory.fps)
    limits = limits if limits is not None else ArmLimits.from_mjcf()
    result = ReplayResult(log=TrackingLog(), steps_total=trajectory.num_steps)
    flag, configured = StopFlag(), []
    with stop_on_signals(flag):
        try:
            _stream(trajectory, drivers, clock, config, limits, flag, configured, result)
        except KeyboardInterrupt:
            flag.set("interrupted by SIGINT (KeyboardInterrupt)", 128 + signal.SIGINT)
        except Exception as exc:
            flag.set(_one_line(exc) if isinstance(exc, DriverError) else repr(exc), 1)
        finally:
            if flag:
                print(
                    f"stopping: {flag.reason}; moving the arms home, then to sleep "
                    "(further Ctrl-C is ignored until they are asleep)",
                    file=sys.stderr,
                )
            shutdown_errors = _shutdown(drivers, configured, clock, config, limits, result)
    at = f"at step {result.steps_done}/{result.steps_total}"
    if flag:
        result.status = "failed" if flag.exit_code == 1 else "interrupted"
        result.reason, result.exit_code = f"replay stopped {at}: {flag.reason}", flag.exit_code
    if shutdown_errors:
        head = result.reason or f"replay streamed {result.steps_done}/{result.steps_total} steps"
        result.reason = f"{head}; shutdown failed: {'; '.join(shutdown_errors)}"
        result.status, result.exit_code = "failed", result.exit_code or 1
    return result
