"""Stopping replay cleanly: a stop flag that SIGINT, SIGTERM, SIGHUP and SIGQUIT set.

While :func:`stop_on_signals` is active (main thread only; elsewhere it does nothing), each
of :data:`STOP_SIGNALS` goes to :meth:`StopFlag.on_signal`: before any arm may move (not
*armed*) it raises :class:`Interrupted` (a ``KeyboardInterrupt``); while streaming (armed) it
records the reason and exit status ``128 + signal number``, which replay checks every
:data:`WAIT_SLICE` s before its safe exit; after streaming (*closed*) it is only noted in
:attr:`StopFlag.late`, so the home moves and result files finish. SIGKILL cannot be handled.
The previous handlers are restored on leaving the ``with`` block.

Docs: docs/cli/replay-real.md, docs/troubleshooting.md.
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
