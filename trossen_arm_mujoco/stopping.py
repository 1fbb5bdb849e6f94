"""Stop signals, in one place: which signals stop a command, their handlers installed and put
back, and what a signal does (:class:`StopSignals`, by mode): raise at once
(``KeyboardInterrupt``, or :class:`Terminated`), be recorded as a request the command polls,
or only be noted. ``errors.run_cli``, ``replay-real`` and ``serve`` are all built on it.

Docs: docs/reference/errors.md; why requests: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = [
    "NOTE",
    "PARENT_ENDED",
    "POLL_S",
    "RAISE",
    "REQUEST",
    "STOP_SIGNALS",
    "TERMINATING_SIGNALS",
    "StopSignals",
    "Terminated",
    "interrupt_signal",
    "redeliver_if_in_finalizer",
    "signal_name",
    "stop_exception",
    "stops_handling",
]

#: Signals a user stops a command with: Ctrl-C, ``kill``, a closed terminal, Ctrl-\.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name)
    for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT")
    if hasattr(signal, name)
)
#: Besides SIGINT, the signals whose default action ends the process (``run_cli`` raises
#: them). Not SIGKILL (it cannot be caught), nor the faults (SIGSEGV...): nothing runs after.
TERMINATING_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name)
    for name in (
        "SIGTERM",
        "SIGHUP",
        "SIGQUIT",
        "SIGUSR1",
        "SIGUSR2",
        "SIGALRM",
        "SIGVTALRM",
        "SIGPROF",
        "SIGXCPU",
    )
    if hasattr(signal, name)
)

#: Modes of :class:`StopSignals`: a signal raises at once (``stop_exception``) ...
RAISE = "raise"
#: ... is recorded as a stop request (:attr:`StopSignals.requested`) ...
REQUEST = "request"
#: ... or is only noted (:attr:`StopSignals.late`): the work under way runs to its end.
NOTE = "note"

#: How often :meth:`StopSignals.wait` looks for a request (s).
POLL_S: float = 0.05
#: :attr:`StopSignals.reason` of a stop because the watched parent process ended.
PARENT_ENDED = "its parent process ended"


class Terminated(KeyboardInterrupt):
    """SIGTERM (or another signal that would end the process) raised in the main thread.

    A ``KeyboardInterrupt``, so code that cleans up after Ctrl-C cleans up after SIGTERM
    alike; ``run_cli`` exits with status 128 + :attr:`signum` (143 for SIGTERM).
    """

    def __init__(self, signum: int = signal.SIGTERM) -> None:
        super().__init__(signal_name(signum))
        self.signum = int(signum)

    def __reduce__(self):  # the signal number survives pickling (worker pools)
        return (type(self), (self.signum,))


def signal_name(signum: int) -> str:
    """``SIGTERM`` for 15; ``signal N`` for an unknown number."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def stop_exception(signum: int) -> KeyboardInterrupt:
    """What a stop signal raises: ``KeyboardInterrupt`` for SIGINT, else :class:`Terminated`."""
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)


def interrupt_signal(exc: KeyboardInterrupt, stops: StopSignals | None = None) -> int:
    """The signal behind ``exc``: a :class:`Terminated`'s own; else the first one ``stops``
    raised (a handler's exception caught and raised again as a plain one); else SIGINT."""
    if isinstance(exc, Terminated):
        return exc.signum
    return stops.received[0] if stops is not None and stops.received else int(signal.SIGINT)


#: Modules whose functions run as finalizers (weakref callbacks).
_FINALIZER_FILES = ("weakref.py", "_weakrefset.py")


def redeliver_if_in_finalizer(signum: int, frame: Any) -> bool:
    """For a signal handler that raises: when the interrupted ``frame`` runs inside a
    finalizer (``__del__``, a weakref callback), an exception raised there is printed as
    "Exception ignored in ..." with a traceback and then lost. Then this signals the process
    again a moment later (a timer thread; Python runs the handler in the main thread, once
    the finalizer has returned) and returns True: the handler returns without raising."""
    if not _in_finalizer(frame):
        return False
    timer = threading.Timer(0.002, os.kill, (os.getpid(), signum))
    timer.daemon = True
    timer.start()
    return True


def _in_finalizer(frame: Any, depth: int = 64) -> bool:
    """Whether ``frame`` (the one a signal interrupted) runs inside a finalizer."""
    while frame is not None and depth > 0:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.endswith(_FINALIZER_FILES):
            return True
        frame, depth = frame.f_back, depth - 1
    return False


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


class StopSignals:
    """The handler of ``signals``; what a signal does is :attr:`mode`'s (``RAISE``,
    ``REQUEST``, ``NOTE``), and a command changes it as its work goes on. Handlers are set
    in the main thread only (elsewhere nothing changes); a signal ignored (``nohup``) or
    handled outside Python stays so.

    Args:
        mode: what a signal does at first.
        signals: the signals handled (default :data:`STOP_SIGNALS`).

    Attributes:
        received: the signals raised or recorded, in order.
        late: the signals only noted (``NOTE``), in order.
        keep: set by a command once it serves: when it returns its process is about to
            exit, and its entry point then :meth:`ignore` s the signals instead of
            :meth:`restore` (a late one changes neither the exit status nor the output).
    """

    def __init__(self, mode: str = REQUEST, signals: Iterable[int] = STOP_SIGNALS) -> None:
        if mode not in (RAISE, REQUEST, NOTE):
            raise ValueError(f"mode must be {RAISE!r}, {REQUEST!r} or {NOTE!r}, got {mode!r}")
        self.mode = mode
        self.signals = tuple(signals)
        self.received: list[int] = []
        self.late: list[int] = []
        self.keep = False
        self._first: tuple[str, int, bool] | None = None  # reason, exit status, by a signal
        self._previous: dict[int, Any] = {}
        self._then: str | None = None  # the mode after one raise (interruptible)
        self._reported = 1  # signals already reported (the first one is the request)
        self._parent: int | None = None

    # --- handlers ------------------------------------------------------------------------

    def handle(self, signum: int, frame: Any) -> None:
        """The signal handler (see :attr:`mode`)."""
        if self.mode == NOTE:
            self.late.append(signum)
            return
        if self.mode == RAISE:
            if redeliver_if_in_finalizer(signum, frame):
                return  # raised there it would be lost: handled again in a moment
            if self._then is not None:
                self.mode, self._then = self._then, None
            self._record(signum)
            raise stop_exception(signum)
        self._record(signum)

    def _take(self, over: Iterable[int] | None) -> dict[int, Any]:
        """Install :meth:`handle`; returns the handlers it replaced. Python's default ones
        are always replaced; another Python handler only where ``over`` is None or names
        the signal."""
        if not _main_thread():
            return {}
        over = None if over is None else {int(s) for s in over}
        replaced = {}
        for sig in self.signals:
            old = signal.getsignal(sig)
            if old in (signal.SIG_IGN, None) or old == self.handle:
                continue
            default = old in (signal.SIG_DFL, signal.default_int_handler)
            if not default and over is not None and int(sig) not in over:
                continue
            signal.signal(sig, self.handle)
            replaced[int(sig)] = old
        return replaced

    def install(self, over: Iterable[int] | None = None) -> StopSignals:
        """Handle :attr:`signals`: in place of Python's default handlers always, of another
        Python handler only where ``over`` is None (default) or names the signal. Again
        after another handler replaced one: reinstalls it; what was first replaced is what
        :meth:`restore` puts back."""
        for sig, old in self._take(over).items():
            self._previous.setdefault(sig, old)
        return self

    def restore(self) -> None:
        """Put back the handlers :meth:`install` and :meth:`ignore` replaced (idempotent)."""
        if not _main_thread():
            return
        for sig, old in self._previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
        self._previous.clear()

    @contextmanager
    def handling(self, over: Iterable[int] | None = None) -> Iterator[StopSignals]:
        """:meth:`install` for the block; the handlers it replaced are put back after (none
        when this object already handles them: an inner block changes nothing)."""
        replaced = self._take(over)
        try:
            yield self
        finally:
            for sig, old in replaced.items():
                signal.signal(sig, old)

    def ignore(self) -> None:
        """Ignore :attr:`signals` from now on: for a process whose work is done and that is
        about to exit. A Python handler would not do: the interpreter puts the default action
        back while it finalizes, so a signal then would still kill the process (exit status
        143), after a clean stop."""
        if not _main_thread():
            return
        for sig in self.signals:
            self._previous.setdefault(int(sig), signal.getsignal(sig))
            signal.signal(sig, signal.SIG_IGN)

    @contextmanager
    def interruptible(self) -> Iterator[None]:
        """Inside the block, the first signal raises (:func:`stop_exception`), to end a wait
        nothing else ends (a blocking lock); later ones are recorded again. A signal received
        before the block raises at its start."""
        if self.received:
            raise stop_exception(self.received[0])
        before, self.mode, self._then = self.mode, RAISE, self.mode
        try:
            yield
        finally:
            self.mode, self._then = before, None

    # --- the stop ------------------------------------------------------------------------

    def _record(self, signum: int) -> None:
        self.received.append(signum)
        if self._first is None:
            self._first = (signal_name(signum), 128 + signum, True)

    def request(self, reason: str, exit_code: int = 1) -> None:
        """A stop the command asks for itself (an error): the first stop, a signal or this,
        gives :attr:`reason` and :attr:`exit_code`."""
        if self._first is None:
            self._first = (reason, int(exit_code), False)

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
        """Whether a stop came: a signal (raised or recorded), :meth:`request`, or the
        watched parent's end."""
        return self._first is not None or self.parent_ended

    @property
    def reason(self) -> str:
        """The first stop's: a signal's name (``SIGINT``...), :meth:`request`'s reason, or
        :data:`PARENT_ENDED`; empty before any."""
        if self._first is not None:
            return self._first[0]
        return PARENT_ENDED if self.parent_ended else ""

    @property
    def exit_code(self) -> int:
        """The first stop's exit status: 128 + the signal's number, or :meth:`request`'s;
        0 before any (and for the parent's end)."""
        return self._first[1] if self._first is not None else 0

    @property
    def by_signal(self) -> bool:
        """Whether the first stop was a signal."""
        return self._first is not None and self._first[2]

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


def stops_handling(sig: int) -> StopSignals | None:
    """The :class:`StopSignals` whose handler ``sig`` has now, if any."""
    owner = getattr(signal.getsignal(sig), "__self__", None)
    return owner if isinstance(owner, StopSignals) else None


def _defaults_in_child() -> None:
    """A process forked while a command runs (a worker pool) is not the command: its stop
    signals get Python's default handling back, instead of stopping a copy of the command."""
    for sig in (signal.SIGINT, *TERMINATING_SIGNALS):
        if stops_handling(sig) is not None:
            default = signal.default_int_handler if sig == signal.SIGINT else signal.SIG_DFL
            signal.signal(sig, default)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_defaults_in_child)
