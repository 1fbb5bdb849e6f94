"""Time sources for replay: wall-clock time for real arms, simulated time for the twin.

Replay never calls :func:`time.sleep` or :func:`time.monotonic` directly; it asks a
:class:`Clock`. With :class:`WallClock` the real arms move in real time. With
:class:`SimClock` nothing moves between calls: ``sleep(dt)`` advances every attached
simulated arm by ``dt`` seconds of physics (as fast as the CPU allows) and then
advances ``now()``. Both arms of a bimanual replay share one clock, so they stay in
step, exactly as two real arms share the wall clock. ``SimClock(realtime=True)`` also
lets each ``sleep(dt)`` take ``dt`` of wall-clock time (simulating, then sleeping the
rest), so a rehearsal on the twin runs at the real arms' pace (``--realtime``).

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

import time
from typing import Protocol, runtime_checkable

__all__ = ["Advanceable", "Clock", "SimClock", "WallClock"]


@runtime_checkable
class Clock(Protocol):
    """A monotonic time source that can wait."""

    def now(self) -> float:
        """Current time (s), monotonic; only differences are meaningful."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` (s) pass; non-positive values return at once."""
        ...


class WallClock:
    """Real time: :func:`time.monotonic` and :func:`time.sleep`."""

    def now(self) -> float:
        """Monotonic wall-clock time (s)."""
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        """Block the process for ``seconds`` (s) of real time."""
        if seconds > 0:
            time.sleep(seconds)


@runtime_checkable
class Advanceable(Protocol):
    """Something that simulates forward in time (a simulated arm)."""

    def advance(self, seconds: float) -> None:
        """Simulate ``seconds`` (s) of physics."""
        ...


class SimClock:
    """Simulated time that drives attached simulations.

    ``sleep(dt)`` advances each attached object (see :meth:`attach`) by ``dt`` and then
    adds ``dt`` to :meth:`now`. It starts at 0 s. Subclass and override
    :meth:`sleep` to inject events at chosen times (tests do this).

    Args:
        realtime: pace to the wall clock: ``sleep(dt)`` returns no sooner than ``dt`` of
            real time after it was called (it takes longer only when simulating ``dt``
            does); replay's waits come in short slices, so it stays interruptible.
    """

    def __init__(self, realtime: bool = False) -> None:
        self._time = 0.0
        self._sims: list[Advanceable] = []
        self.realtime = realtime

    def attach(self, sim: Advanceable) -> None:
        """Advance ``sim`` whenever this clock sleeps (idempotent)."""
        if not any(s is sim for s in self._sims):
            self._sims.append(sim)

    def now(self) -> float:
        """Simulated time since construction (s)."""
        return self._time

    def sleep(self, seconds: float) -> None:
        """Simulate ``seconds`` (s) on every attached simulation, then advance the time."""
        if seconds <= 0:
            return
        start = time.monotonic()
        for sim in self._sims:
            sim.advance(seconds)
        self._time += seconds
        if self.realtime:
            left = seconds - (time.monotonic() - start)
            if left > 0:
                time.sleep(left)
