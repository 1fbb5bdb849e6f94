r"""Driver calls that fail in one line, and the safe exit: home, sleep and clean up every arm.

Every driver call of replay goes through :func:`call`, which turns *any* exception into a
:class:`DriverError` naming the arm and the call; :func:`read_positions` checks positions
read (7 finite values). :func:`shutdown` runs after streaming, whatever stopped it, for each
arm on its own: position mode where missing, home then sleep pose (goal times from the
measured position and the speed limits), final read, cleanup. Each call is tried twice;
failures are collected, never raised; an arm whose home move cannot be sent is given up
(only its cleanup follows). ``Exception`` and ``KeyboardInterrupt`` are caught; other
``BaseException``\ s (``SystemExit``, a test framework's failure) are not.

Docs: docs/cli/replay-real.md; the sequence in full: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.clock import Clock
from trossen_arm_mujoco.real.driver import HOME_POSE, NUM_ARM_VALUES, SLEEP_POSE, ArmDriver
from trossen_arm_mujoco.real.validate import ArmLimits, safe_move_time

__all__ = [
    "SHUTDOWN_TRIES",
    "ArmStates",
    "DriverError",
    "call",
    "move_time",
    "one_line",
    "read_positions",
    "shutdown",
]

#: Attempts of each call during shutdown.
SHUTDOWN_TRIES: int = 2


class DriverError(RuntimeError):
    """A driver call failed; the message names the arm and the call."""


@dataclass
class ArmStates:
    """How far each arm got: lists of arm names, in the order reached."""

    attempted: list[str] = field(default_factory=list)  # configure was called
    configured: list[str] = field(default_factory=list)  # configure returned
    position_mode: list[str] = field(default_factory=list)  # set_all_modes_position returned


def one_line(exc: BaseException) -> str:
    """``exc`` as one line; the exception type is named unless it is a runtime/user error."""
    text = " ".join(str(exc).split())
    if isinstance(exc, (RuntimeError, UserError, OSError)) and text:
        return text
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def call(side: str, what: str, fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)``; any exception becomes a :class:`DriverError` naming arm and call.

    Args:
        side: the arm, ``"left"`` or ``"right"``.
        what: the call's name, for the message.
        fn: the driver method.
        *args: its arguments.
    """
    try:
        return fn(*args)
    except DriverError:
        raise
    except Exception as exc:
        raise DriverError(f"{side} arm: {what} failed: {one_line(exc)}") from exc


def read_positions(side: str, driver: ArmDriver) -> np.ndarray:
    """Measured positions of one arm, checked: float64 ``(7,)``, finite.

    Raises:
        DriverError: the call failed or returned something else.
    """

    def read() -> np.ndarray:
        raw = driver.get_all_positions()
        pos = np.asarray(raw, dtype=np.float64)
        if pos.shape != (NUM_ARM_VALUES,) or not np.all(np.isfinite(pos)):
            got = f"shape {pos.shape}" if pos.shape != (NUM_ARM_VALUES,) else "non-finite values"
            raise ValueError(f"returned {got}, expected {NUM_ARM_VALUES} finite values")
        return pos

    return call(side, "get_all_positions", read)


def move_time(
    start: np.ndarray | None, goal: np.ndarray, minimum: float, limits: ArmLimits
) -> float:
    """Goal time (s) of a move within the speed limits.

    Args:
        start: ``(7,)`` driver values where the arm is; None when unknown (then the
            farthest point of the joint ranges).
        goal: ``(7,)`` driver values to reach.
        minimum: the shortest goal time (s).
        limits: the arm's limits.
    """
    if start is None:
        lo, hi = limits.driver_lower, limits.driver_upper
        start = np.where(np.abs(goal - lo) > np.abs(hi - goal), lo, hi)
    return safe_move_time(start, goal, minimum, limits)


def _attempt(
    errors: list[str], side: str, what: str, fn: Callable[..., Any], *args: Any
) -> tuple[bool, Any]:
    """Try ``call(side, what, fn, *args)`` up to SHUTDOWN_TRIES times; record failures.

    Returns:
        ``(True, value)`` once a try succeeds, ``(False, None)`` when every try failed.
    """
    failures: list[str] = []
    for _ in range(SHUTDOWN_TRIES):
        try:
            value = call(side, what, fn, *args)
        except DriverError as exc:
            failures.append(str(exc))
            continue
        except KeyboardInterrupt as exc:  # not wrapped by call()
            failures.append(f"{side} arm: {what} failed: {one_line(exc)}")
            continue
        if failures:
            errors.append(f"{failures[0]} (the retry succeeded)")
        return True, value
    errors.append(f"{failures[-1]} (failed {len(failures)} times)")
    return False, None


def _wait(errors: list[str], clock: Clock, seconds: float) -> None:
    try:
        clock.sleep(seconds)
    except (Exception, KeyboardInterrupt) as exc:
        errors.append(f"waiting for the arms failed: {one_line(exc)}")


def shutdown(
    drivers: Mapping[str, ArmDriver],
    states: ArmStates,
    clock: Clock,
    home_time: float,
    sleep_time: float,
    settle_time: float,
    limits: ArmLimits,
) -> tuple[dict[str, np.ndarray], list[str]]:
    """Home, sleep, clean up; see the module doc. Never raises ``Exception``.

    Args:
        drivers: arm name -> driver.
        states: how far each arm got (which were configured, in position mode).
        clock: the clock to wait on.
        home_time: the shortest goal time of the home move (s).
        sleep_time: the shortest goal time of the sleep move (s).
        settle_time: the wait after each move (s).
        limits: the arms' limits (goal times within the speed limits).

    Returns:
        ``({arm: final (7,) positions}, errors)``: positions of the arms that could be
        read after the sleep move, and one line per failed call.
    """
    errors: list[str] = []
    sides = list(states.configured)
    lost: list[str] = []  # arms given up: their home move could not be sent
    for side in sides:
        if side not in states.position_mode:
            _attempt(errors, side, "set_all_modes_position", drivers[side].set_all_modes_position)
    for name, pose, minimum in (("home", HOME_POSE, home_time), ("sleep", SLEEP_POSE, sleep_time)):
        goal = np.asarray(pose, dtype=np.float64)
        goal_times = []
        for side in sides:
            if side in lost:
                continue
            drv = drivers[side]
            try:
                ok, start = _attempt(errors, side, "get_all_positions", read_positions, side, drv)
                goal_time = move_time(start if ok else None, goal, minimum, limits)
                what = f"set_all_positions ({name})"
                sent, _ = _attempt(
                    errors, side, what, drv.set_all_positions, goal.copy(), goal_time, False
                )
                if sent:
                    goal_times.append(goal_time)
                elif name == "home":
                    lost.append(side)
                    errors.append(
                        f"{side} arm: given up (its controller does not answer): not homed, "
                        "not asleep, left where it stopped"
                    )
            except (Exception, KeyboardInterrupt) as exc:  # a bug here must not stop the exit
                errors.append(f"{side} arm: {name} move failed: {one_line(exc)}")
        if goal_times:
            _wait(errors, clock, max(goal_times) + settle_time)
    final: dict[str, np.ndarray] = {}
    for side in sides:
        if side in lost:
            continue
        ok, pos = _attempt(errors, side, "get_all_positions", read_positions, side, drivers[side])
        if ok:
            final[side] = pos
    for side in states.attempted:
        _attempt(errors, side, "cleanup", drivers[side].cleanup)
    return final, errors
