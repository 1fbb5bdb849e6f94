"""Stop signals as requests: a long-running command (``serve``) that stops cleanly however
many signals arrive, in whatever order.

:class:`StopSignals` never raises (except inside :meth:`StopSignals.interruptible`): SIGINT,
SIGTERM and SIGHUP are recorded, the command polls :attr:`StopSignals.requested` and runs its
shutdown to the end; a repeated signal is reported (:meth:`StopSignals.new_repeats`).
:meth:`StopSignals.watch_parent` also stops a child once its parent is gone.

Docs: docs/cli/serve.md; why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from trossen_arm_mujoco.errors import Terminated, redeliver_if_in_finalizer

__all__ = ["PARENT_ENDED", "POLL_S", "STOP_SIGNALS", "StopSignals", "signal_name"]

#: Signals that request a stop: Ctrl-C, ``kill``, a closed terminal.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)
#: How often :meth:`StopSignals.wait` looks for a request (s).
POLL_S: float = 0.05
#: :attr:`StopSignals.reason` of a stop because the watched parent process ended.
PARENT_ENDED = "its parent process ended"


def signal_name(signum: int) -> str:
    """``SIGTERM`` for 15; ``signal N`` for an unknown number."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class StopSignals:
    """Records :data:`STOP_SIGNALS` as stop requests once :meth:`install` ed; see the
    module doc. A signal ignored when it is installed (``nohup``) stays ignored.

    Attributes:
        received: the signals received, in order.
        keep: set by the command once it serves: when it returns, its process is about to
            exit, and its entry point then :meth:`ignore` s the stop signals (a late one
            changes neither the exit status nor the output) instead of :meth:`restore`.
    """

    def __init__(self) -> None:
        self.received: list[int] = []
        self.keep = False
        self._previous: dict[int, Any] = {}
        self._raising = False
        self._reported = 1  # signals already reported (the first one is the request)
        self._parent: int | None = None

    def install(self) -> StopSignals:
        """Handle the stop signals (main thread only; elsewhere a no-op). Again after
        another handler replaced one: reinstalls it (the handlers first replaced are what
        :meth:`restore` puts back)."""
        if threading.current_thread() is not threading.main_thread():
            return self
        for sig in STOP_SIGNALS:
            old = signal.getsignal(sig)
            if old == signal.SIG_IGN or old == self._handle:
                continue
            self._previous.setdefault(int(sig), old)
            signal.signal(sig, self._handle)
        return self

    def restore(self) -> None:
        """Put back the handlers :meth:`install` replaced (idempotent)."""
        if threading.current_thread() is not threading.main_thread():
            return
        for sig, old in self._previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
        self._previous.clear()

    def ignore(self) -> None:
        """Ignore the stop signals from now on (main thread only): for a process whose work
        is done and that is about to exit. A Python handler would not do: the interpreter
        puts the default action back while it finalizes, so a signal then would still
        kill the process (exit status 143), after a clean stop."""
        if threading.current_thread() is not threading.main_thread():
            return
        for sig in STOP_SIGNALS:
            self._previous.setdefault(int(sig), signal.getsignal(sig))
            signal.signal(sig, signal.SIG_IGN)

    def _handle(self, signum: int, frame: Any) -> None:
        if self._raising:
            if redeliver_if_in_finalizer(signum, frame):
                return  # raised there it would be lost: handled again in a moment
            self._raising = False
            self.received.append(signum)
            raise KeyboardInterrupt if signum == signal.SIGINT else Terminated(signum)
        self.received.append(signum)

    def watch_parent(self, pid: int | None) -> StopSignals:
        """Also count as a stop request that process ``pid`` is no longer this process's
        parent (it ended: the process was handed to another one); None: no watch."""
        self._parent = None if pid is None else int(pid)
        return self

    @property
    def parent_ended(self) -> bool:
        """Whether the watched parent process (:meth:`watch_parent`) is gone."""
        return self._parent is not None and os.getppid() != self._parent

    @property
    def requested(self) -> bool:
        """Whether a stop signal arrived (or the watched parent process ended)."""
        return bool(self.received) or self.parent_ended

    @property
    def reason(self) -> str:
        """The first signal's name (``SIGINT``, ``SIGTERM``...), else :data:`PARENT_ENDED`
        once the watched parent is gone; empty before either."""
        if self.received:
            return signal_name(self.received[0])
        return PARENT_ENDED if self.parent_ended else ""

    def wait(self, seconds: float | None = None) -> bool:
        """Sleep until a stop is requested (or ``seconds`` passed); returns :attr:`requested`."""
        end = None if seconds is None else time.monotonic() + seconds
        while not self.requested:
            left = POLL_S if end is None else min(POLL_S, end - time.monotonic())
            if left <= 0:
                break
            time.sleep(left)
        return self.requested

    def new_repeats(self) -> list[str]:
        """Names of the signals received after the first one since the last call."""
        names = [signal_name(s) for s in self.received[self._reported :]]
        self._reported = max(self._reported, len(self.received))
        return names

    @contextmanager
    def interruptible(self) -> Iterator[None]:
        """Inside the block, the first stop signal raises (``KeyboardInterrupt`` for SIGINT,
        ``errors.Terminated`` for the others), to end a wait nothing else ends (a blocking
        lock); a stop requested before the block raises at its start."""
        if self.received:
            signum = self.received[0]
            raise KeyboardInterrupt if signum == signal.SIGINT else Terminated(signum)
        self._raising = True
        try:
            yield
        finally:
            self._raising = False
