"""When a served leader pair's replay runs: the clock both arms read (``twin.leaders``).

The replay starts once every arm's client is ready (both in ``external_effort`` mode) or on
:meth:`ReplayClock.trigger`, after a lead-in and an optional approach, and plays at a speed
(:func:`check_speed`).

Docs: docs/cli/serve.md, docs/cli/teleop.md.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import SIDES

__all__ = ["LEAD_IN_S", "SPEED_RANGE", "ReplayClock", "check_speed"]

#: Seconds the arms hold the first pose after both are in external_effort mode.
LEAD_IN_S: float = 1.0
#: Replay speeds accepted (1.0 = as recorded).
SPEED_RANGE: tuple[float, float] = (0.05, 10.0)


class ReplayClock:
    """When the replay runs, shared by both arms.

    The replay time (s into the episode) is 0 until :meth:`client_ready` has been called
    for every side (or :meth:`trigger`), then after ``lead_in`` s (and the approach, if
    any) runs at ``speed`` up to ``duration`` and stays there. :attr:`started` and
    :attr:`finished` are set as those moments pass (checked whenever the time is read, and
    by :meth:`poll`). ``approach``, when given, is called once at the trigger and returns
    the seconds the arms take from their rest poses to the episode's first pose
    (:attr:`approach_s`), spent right after the lead-in at wall-clock speed.

    Args:
        duration: the episode's length (s).
        speed: replay speed (1.0: as recorded).
        lead_in: seconds from the trigger to the replay (or its approach).
        sides: the arms whose clients must be ready.
        now: the clock (s), ``time.monotonic`` by default.
        approach: called once at the trigger; returns the approach's seconds.
    """

    def __init__(
        self,
        duration: float,
        speed: float = 1.0,
        lead_in: float = LEAD_IN_S,
        sides: tuple[str, ...] = SIDES,
        now: Callable[[], float] = time.monotonic,
        approach: Callable[[], float] | None = None,
    ) -> None:
        self.duration = float(duration)
        self.approach = approach
        #: Seconds of the approach (set at the trigger).
        self.approach_s = 0.0
        self.speed = float(speed)
        self.lead_in = float(lead_in)
        self.sides = tuple(sides)
        self.now = now
        self.ready: set[str] = set()
        #: Monotonic time (s) at which the replay leaves the first pose (None: not yet).
        self.start_time: float | None = None
        self.triggered = threading.Event()
        self.started = threading.Event()
        self.finished = threading.Event()
        self._lock = threading.Lock()

    def client_ready(self, side: str) -> None:
        """A client put arm ``side`` in external_effort mode."""
        if self.start_time is not None or side in self.ready:
            return
        with self._lock:
            self.ready.add(side)
            if self.ready.issuperset(self.sides):
                self._trigger_locked()

    def trigger(self) -> None:
        """Start now (the replay leaves the first pose ``lead_in`` s from now)."""
        with self._lock:
            self._trigger_locked()

    def _trigger_locked(self) -> None:
        if self.start_time is None:
            if self.approach is not None:
                self.approach_s = max(0.0, float(self.approach()))
            self.start_time = self.now() + self.lead_in
            self.triggered.set()

    def phase(self) -> tuple[str, float]:
        """Where the replay is now: ``("rest", 0.0)`` before it starts, ``("approach",
        fraction)`` (0 .. 1) while the arms move to the episode's first pose, ``("play",
        seconds)`` (0 .. duration) once the episode plays."""
        start = self.start_time
        if start is None:
            return "rest", 0.0
        wall = self.now() - start
        if wall < 0.0:
            return "rest", 0.0
        self.started.set()
        if wall < self.approach_s:
            return "approach", wall / self.approach_s
        elapsed = (wall - self.approach_s) * self.speed
        if elapsed >= self.duration:
            self.finished.set()
            return "play", self.duration
        return "play", elapsed

    def replay_time(self) -> float:
        """Seconds into the episode now (0 .. duration)."""
        kind, value = self.phase()
        return value if kind == "play" else 0.0

    def poll(self) -> None:
        """Update :attr:`started` / :attr:`finished` (no client needs to be reading)."""
        self.replay_time()


def check_speed(speed: float) -> float:
    """``speed`` when it is a replay speed in :data:`SPEED_RANGE`; else a ``UserError``."""
    lo, hi = SPEED_RANGE
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not lo <= speed <= hi:
        raise UserError(f"replay speed must be a number in [{lo:g}, {hi:g}], got {speed!r}")
    return float(speed)
