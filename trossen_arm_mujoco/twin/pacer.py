"""Pacing a simulation to wall-clock time: the deadlines, whether it keeps up, how fast it ran.

A :class:`Pacer` is called once per simulated step of ``dt`` seconds: it sleeps until that
step's deadline, so simulated time follows the wall clock. A simulation that falls behind
catches up by not sleeping; once :data:`MAX_LAG_S` behind it gives up (the lost time is
dropped, counted in ``resyncs``) rather than spiral. :attr:`Pacer.on_time` says whether the
simulation keeps real time now: at most :data:`ON_TIME_S` late, and not within
:data:`UNSURE_AFTER_LAG_S` of giving up.

Docs: docs/cli/serve.md.
"""

from __future__ import annotations

import time

__all__ = ["MAX_LAG_S", "ON_TIME_S", "UNSURE_AFTER_LAG_S", "Pacer"]

#: The simulation gives up catching up with wall-clock time when this far behind (s).
MAX_LAG_S: float = 0.1
#: A simulation at most this late keeps real time (s).
ON_TIME_S: float = 0.01
#: After giving up catching up, the simulation counts as late for this long (s).
UNSURE_AFTER_LAG_S: float = 0.5


class Pacer:
    """Deadlines every ``dt`` seconds from :meth:`start`; see the module doc."""

    def __init__(self, dt: float) -> None:
        self.dt = float(dt)
        self.resyncs = 0
        self.on_time = True
        self.steps = 0
        self._deadline = self._trusted_from = self._start = 0.0
        self._stop: float | None = None

    def start(self) -> None:
        """Begin at the current time (resets the step count)."""
        now = time.perf_counter()
        self._deadline = self._trusted_from = self._start = now
        self._stop, self.steps = None, 0

    def pace(self) -> None:
        """One step of ``dt`` done: wait for its deadline (or note being late)."""
        self.steps += 1
        self._deadline += self.dt
        now = time.perf_counter()
        delay = self._deadline - now
        if delay > 0:
            time.sleep(delay)
        elif delay < -MAX_LAG_S:  # fell behind: carry on from now, do not spiral
            self._deadline = now
            self.resyncs += 1
            self._trusted_from = now + UNSURE_AFTER_LAG_S
        self.on_time = delay > -ON_TIME_S and now >= self._trusted_from

    def stop(self) -> None:
        """End pacing: the real-time factor is taken up to now."""
        self._stop = time.perf_counter()
        self.on_time = True

    @property
    def realtime_factor(self) -> float:
        """Simulated over wall-clock time from :meth:`start` to :meth:`stop` (or now);
        1.0 is real time, NaN before :meth:`start`."""
        if not self._start:
            return float("nan")
        wall = (self._stop if self._stop is not None else time.perf_counter()) - self._start
        return self.steps * self.dt / wall if wall > 0 else float("nan")
