"""Stopping replay cleanly: a stop flag that SIGINT and SIGTERM set instead of raising.

While :func:`stop_on_signals` is active (main thread only; elsewhere signals cannot be
handled and it does nothing), SIGINT and SIGTERM record a reason and exit status
``128 + signal number`` in a :class:`StopFlag`; the replay loop checks the flag before
every step and then runs its safe home/sleep exit. The previous handlers are restored
on leaving the ``with`` block, whatever happened inside.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class StopFlag:
    """Set once, by a signal handler or an error, to end streaming."""

    def __init__(self) -> None:
        self.reason: str | None = None
        self.exit_code = 0

    def set(self, reason: str, exit_code: int) -> None:
        """Record the first stop reason; later ones are ignored."""
        if self.reason is None:
            self.reason, self.exit_code = reason, exit_code

    def __bool__(self) -> bool:
        return self.reason is not None


@contextmanager
def stop_on_signals(flag: StopFlag) -> Iterator[StopFlag]:
    """Make SIGINT/SIGTERM set ``flag`` instead of raising; restore the handlers after."""
    previous: dict[int, Any] = {}

    def handler(signum: int, _frame: Any) -> None:
        flag.set(f"interrupted by {signal.Signals(signum).name}", 128 + signum)

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)
    try:
        yield flag
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
