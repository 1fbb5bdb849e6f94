"""Leader arms read through the unmodified ``trossen_arm`` driver, for teleoperation.

:class:`LeaderArms` reads a pair of leader arms as Trossen's LeRobot leader teleoperator
does: each is configured with the leader end effector (``StandardEndEffector.wxai_v0_leader``),
put in ``Mode.external_effort`` with zero external efforts (gravity-compensated, moved
freely by hand) and read with ``get_all_positions()``: 7 values per arm, 6 joints (rad) then
the gripper (m, one finger's travel). Real leader arms and the served ones of
``trossen-mujoco serve --role leader`` (:mod:`.leaders`) read alike. Any driver error
(connection lost, controller error, a bad reading) is a :class:`LeaderFault`: one line
naming the arm. :meth:`LeaderArms.close` calls the driver's ``cleanup``, which leaves the
arms idle (a real leader arm then goes limp: rest it first).

The driver prints its own log lines to stderr; :class:`DriverLog` routes them instead (kept,
or printed with ``verbose``), so that a fault is one line.

Docs: docs/cli/teleop.md.
"""

from __future__ import annotations

import atexit
import sys
import threading
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.driver import (
    DEFAULT_MODEL,
    NUM_ARM_VALUES,
    import_trossen_arm,
    resolve_presets,
)
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, SIDES

__all__ = [
    "CONNECT_TIMEOUT_S",
    "LEADER_END_EFFECTOR",
    "DriverLog",
    "LeaderArms",
    "LeaderFault",
    "first_line",
]

#: End-effector preset of the leader arms (trossen_arm ``StandardEndEffector``).
LEADER_END_EFFECTOR: str = "wxai_v0_leader"
#: Seconds ``configure`` waits for a leader's controller.
CONNECT_TIMEOUT_S: float = 10.0


class LeaderFault(UserError):
    """A leader arm failed (connection lost, controller error, bad reading): one line."""


def first_line(exc: BaseException) -> str:
    """The first line of an exception's text (the driver appends a troubleshooting link)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[0] if lines else type(exc).__name__


class DriverLog:
    """Where the ``trossen_arm`` driver's log messages go while leaders are read.

    The driver prints its own lines (connection progress, retransmission warnings,
    failures) to stderr; a command that promises one line on a fault routes them here
    instead: the last few are kept (:meth:`last`), and with ``verbose`` printed to stderr.
    The backend is process-wide (``TrossenArmDriver.set_logger_backend``), installed once,
    and released at exit (``set_logger_backend(None)``).
    """

    _installed: DriverLog | None = None

    def __init__(self, keep: int = 20) -> None:
        self.messages: deque[tuple[str, str, str]] = deque(maxlen=keep)
        self.verbose = False
        self._lock = threading.Lock()

    @classmethod
    def install(cls, ta: Any, verbose: bool = False) -> DriverLog:
        """The process's router (installed on first use); ``verbose`` prints every line."""
        if cls._installed is None:
            log = cls()
            ta.TrossenArmDriver.set_logger_backend(log._receive)
            # the library keeps the callable in a C++ static, destroyed after the interpreter
            # finalizes: a segfault at exit unless it is released while Python still runs
            atexit.register(ta.TrossenArmDriver.set_logger_backend, None)
            cls._installed = log
        cls._installed.verbose = bool(verbose)
        return cls._installed

    def _receive(self, level: Any, name: str, message: str) -> None:
        level_name = getattr(level, "name", str(level))
        with self._lock:
            self.messages.append((str(level_name), str(name), str(message)))
        if self.verbose:
            print(f"[{name}] [{level_name}] {message}", file=sys.stderr, flush=True)


class LeaderArms:
    """Two leader arms read through ``trossen_arm`` (see the module docstring).

    Args:
        ips: ``{"left": address, "right": address}`` of the leader arms' controllers.
        end_effector: ``StandardEndEffector`` preset name of the leaders.
        model: ``Model`` name of the arms.
        timeout: seconds each ``configure`` waits for its controller.
        verbose: print the driver's own log lines to stderr.
    """

    def __init__(
        self,
        ips: Mapping[str, str],
        end_effector: str = LEADER_END_EFFECTOR,
        model: str = DEFAULT_MODEL,
        timeout: float = CONNECT_TIMEOUT_S,
        verbose: bool = False,
    ) -> None:
        self.ta = import_trossen_arm()
        self.model, self.end_effector = resolve_presets(self.ta, model, end_effector)
        self.end_effector_name = end_effector
        self.ips = {side: str(ips[side]) for side in SIDES}
        if self.ips["left"] == self.ips["right"]:
            raise UserError(
                f"the left and right leader arms need two addresses, got {self.ips['left']} twice"
            )
        self.timeout = float(timeout)
        self.log = DriverLog.install(self.ta, verbose)
        self.drivers: dict[str, Any] = {}

    def _call(self, side: str, what: str, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as exc:
            raise LeaderFault(
                f"{side} leader arm ({self.ips[side]}): {what} failed: {first_line(exc)}"
            ) from None

    def connect(self) -> None:
        """Configure both arms and put them in external_effort mode with zero efforts."""
        ta = self.ta
        for side in SIDES:
            driver = ta.TrossenArmDriver()
            try:
                driver.configure(self.model, self.end_effector, self.ips[side], True, self.timeout)
            except Exception as exc:
                raise LeaderFault(
                    f"cannot connect to the {side} leader arm at {self.ips[side]}: "
                    f"{first_line(exc)}; check that it is on and reachable (simulated leaders: "
                    "trossen-mujoco serve --role leader --replay EPISODE.hdf5)"
                ) from None
            self.drivers[side] = driver
            self._call(
                side,
                "set_all_modes(external_effort)",
                driver.set_all_modes,
                ta.Mode.external_effort,
            )
            self._call(
                side,
                "set_all_external_efforts",
                driver.set_all_external_efforts,
                [0.0] * NUM_ARM_VALUES,
                0.0,
                False,
            )

    def read(self) -> np.ndarray:
        """Both arms now: float64 ``(14,)`` in the kit's layout (left 7, right 7)."""
        out = np.empty(KIT14_LAYOUT.size)
        for i, side in enumerate(SIDES):
            driver = self.drivers.get(side)
            if driver is None:
                raise LeaderFault(f"{side} leader arm ({self.ips[side]}): not connected")
            values = np.asarray(
                self._call(side, "get_all_positions", driver.get_all_positions), dtype=float
            )
            if values.shape != (NUM_ARM_VALUES,) or not np.all(np.isfinite(values)):
                raise LeaderFault(
                    f"{side} leader arm ({self.ips[side]}): get_all_positions returned "
                    f"{values.tolist()!r:.120}, expected {NUM_ARM_VALUES} finite values"
                )
            out[7 * i : 7 * i + 7] = values
        return out

    def close(self) -> None:
        """Release both arms (the driver leaves them idle); never raises."""
        drivers, self.drivers = self.drivers, {}
        for driver in drivers.values():
            try:
                driver.cleanup()
            except Exception:
                pass

    def __enter__(self) -> LeaderArms:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
