"""Stopping replay cleanly: a stop flag that SIGINT, SIGTERM, SIGHUP and SIGQUIT set.

While :func:`stop_on_signals` is active (main thread only; elsewhere signals cannot be
handled and it does nothing), each of :data:`STOP_SIGNALS` is handled the same way, by
:meth:`StopFlag.on_signal`, according to how far the run got:

- before any arm may move (the flag is not *armed*): :class:`Interrupted` is raised, a
  ``KeyboardInterrupt``, so the command ends at once; nothing was sent to an arm and
  nothing is being written;
- while streaming (armed): the reason and exit status ``128 + signal number`` are
  recorded; replay checks the flag while it waits (in slices of :data:`WAIT_SLICE`) and
  then runs its safe home/sleep exit;
- after streaming ended (the flag is *closed*: homing, writing the results): the signal
  is only noted in :attr:`StopFlag.late`; the home/sleep moves and the result files are
  finished, so a late signal never leaves a half-written file or an arm mid-way.

SIGKILL cannot be handled: it is the one way to end a replay at once. The previous
handlers are restored on leaving the ``with`` block, whatever happened inside.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["STOP_SIGNALS", "WAIT_SLICE", "Interrupted", "StopFlag", "stop_on_signals"]

#: Signals that stop a replay cleanly (where the platform has them).
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name)
    for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT")
    if hasattr(signal, name)
)

#: Longest single wait (s) between two checks of the stop flag.
WAIT_SLICE: float = 0.05


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived before any arm could move; ``exit_code`` is 128 + its number."""

    def __init__(self, signum: int) -> None:
        self.signum, self.exit_code = signum, 128 + signum
        super().__init__(f"interrupted by {signal.Signals(signum).name}")


class StopFlag:
    """Set once, by a signal or an error, to end streaming.

    Args:
        armed: False makes a signal raise :class:`Interrupted` (nothing to bring home yet)
            until :meth:`arm` is called; True (default) records it.
    """

    def __init__(self, armed: bool = True) -> None:
        self.reason: str | None = None
        self.exit_code = 0
        self.armed = armed
        self.closed = False
        self.late: list[str] = []

    def set(self, reason: str, exit_code: int) -> None:
        """Record the first stop reason; later ones are ignored."""
        if self.reason is None:
            self.reason, self.exit_code = reason, exit_code

    def arm(self) -> None:
        """From now on a signal is recorded, never raised: an arm may move."""
        self.armed = True

    def close(self) -> None:
        """Streaming is over: later signals only go to :attr:`late`."""
        self.armed = self.closed = True

    def on_signal(self, signum: int) -> None:
        """Handle a stop signal (see the module doc)."""
        if not self.armed:
            raise Interrupted(signum)
        name = signal.Signals(signum).name
        if self.closed:
            self.late.append(name)
        else:
            self.set(f"interrupted by {name}", 128 + signum)

    def __bool__(self) -> bool:
        return self.reason is not None


@contextmanager
def stop_on_signals(flag: StopFlag) -> Iterator[StopFlag]:
    """Route :data:`STOP_SIGNALS` to ``flag.on_signal``; restore the handlers after."""
    previous: dict[int, Any] = {}

    def handler(signum: int, _frame: Any) -> None:
        flag.on_signal(signum)

    try:
        if threading.current_thread() is threading.main_thread():
            for sig in STOP_SIGNALS:
                previous[sig] = signal.signal(sig, handler)
        yield flag
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
