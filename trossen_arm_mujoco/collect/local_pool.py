"""Local worker processes that survive the death of a worker.

``multiprocessing.Pool`` waits forever for the result of a killed worker (the OOM killer,
``kill -9``). :class:`WorkerPool` gives each worker its own pipe and watches its process: a
worker that dies loses only the job it was running, which runs again in a new worker
(``max_tries`` tries in all). Results come back as they finish, with their job's position.
Signals end a worker quietly: SIGINT is ignored (the parent decides); SIGTERM becomes
``KeyboardInterrupt`` while it runs jobs, so it discards its partial file; a worker whose
parent dies, even by SIGKILL, gets SIGTERM, so no worker outlives a run.

Docs: docs/cli/record.md; the signal handling in full: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from trossen_arm_mujoco.errors import UserError, redeliver_if_in_finalizer, show_warning_as_note
from trossen_arm_mujoco.processes import parent_death_signal

__all__ = [
    "MAX_TRIES",
    "PARENT_POLL_S",
    "POLL_S",
    "STOP_WAIT_S",
    "RemoteTraceback",
    "WorkerPool",
    "describe_exit",
]

#: Tries of one job, the first included, before a worker dying on it ends the run.
MAX_TRIES = 3

#: Seconds of one wait for a result (Ctrl-C and dead workers are seen between waits).
POLL_S = 0.5

#: Seconds stopped workers get to exit (and remove their partial files) before SIGKILL.
STOP_WAIT_S = 15.0

#: Seconds between two looks at the parent, where its death cannot be signalled (not Linux).
PARENT_POLL_S = 0.5

#: Set in a worker once SIGTERM raised ``KeyboardInterrupt`` in it: it is stopping, and
#: cleaning up (discarding its partial file); more SIGTERMs must not interrupt that.
_stopping = False

#: Set in a worker once it stops running jobs: SIGTERM then ends it at once, quietly.
_done = False


def _raise_interrupt(signum: int, frame: Any) -> None:
    """SIGTERM in a worker: the first raises ``KeyboardInterrupt`` while it runs jobs (so
    that its partial file is discarded); more while it stops are ignored, so that they
    cannot cut its cleanup short; once it is done (:data:`_done`) the signal takes its
    default action, so that a late one cannot raise in the interpreter's exit handlers.

    Several do come: the kernel sends the parent-death signal each time the thread that is
    the worker's parent exits, and the worker is handed to the next thread of the dying
    process, so a parent killed with N threads signals each worker up to N times.
    """
    global _stopping
    if _done:
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)  # ends the process, with no output
        return
    if _stopping:
        return
    if redeliver_if_in_finalizer(signum, frame):  # not inside a finalizer: it would be lost
        return
    _stopping = True
    raise KeyboardInterrupt


def _watch_parent(parent: int, interval: float = PARENT_POLL_S) -> threading.Thread:
    """Send this process SIGTERM once its parent ``parent`` is gone (a daemon thread polling
    ``os.getppid()``, which changes when the process is re-parented)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(interval)
        os.kill(os.getpid(), signal.SIGTERM)

    thread = threading.Thread(target=watch, name="watch-parent", daemon=True)
    thread.start()
    return thread


def _die_with_parent(parent: int) -> None:
    """SIGTERM this process when its parent ``parent`` dies: by the kernel where it can
    (Linux), else by a thread watching the parent.

    Raises:
        KeyboardInterrupt: the parent is gone already.
    """
    request = parent_death_signal(signal.SIGTERM)
    if request is None or not request():
        _watch_parent(parent)
    if os.getppid() != parent:  # the parent died before the kernel was asked
        raise KeyboardInterrupt


def _unblock_sigint() -> None:
    """Unblock SIGINT (blocked by the parent while it started this process)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@contextlib.contextmanager
def _sigint_blocked() -> Iterator[None]:
    """Block SIGINT in this thread for the block: a process started meanwhile inherits the
    blocked signal (through ``exec`` too), so a Ctrl-C during its start-up cannot raise
    ``KeyboardInterrupt`` there. A Ctrl-C meanwhile reaches this process afterwards."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # multiprocessing starts its resource tracker with the first process, and unblocks
    # SIGINT after that: started first, it leaves the mask alone
    with contextlib.suppress(Exception):
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _send(conn: Connection, message: tuple) -> None:
    try:
        conn.send(message)
    except (TypeError, AttributeError, ValueError, RuntimeError) as exc:  # not picklable
        kind, position, error, text = message
        conn.send((kind, position, RuntimeError(f"{type(error).__name__}: {error}"), text))
        del exc


def _worker_main(
    conn: Connection,
    parent: int,
    initializer: Callable[..., None],
    initargs: tuple,
    task: Callable[[Any], Any],
) -> None:
    """Body of one worker process: set up, then run jobs until told to stop (or the parent
    is gone); see the module doc for signals."""
    global _done, _stopping
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        _unblock_sigint()
        signal.signal(signal.SIGTERM, _raise_interrupt)
        _die_with_parent(parent)
        # warnings raised in a worker print as the parent's do: one plain "note:" line
        warnings.showwarning = show_warning_as_note
        try:
            initializer(*initargs)
        except Exception as exc:
            _send(conn, ("error", None, exc, traceback.format_exc()))
            return
        while True:
            _stopping = False  # a job that swallowed an interrupt ran to its end: not stopping
            message = conn.recv()
            if message is None:
                return
            position, payload = message
            try:
                reply = ("ok", position, task(payload), "")
            except Exception as exc:
                reply = ("error", position, exc, traceback.format_exc())
            _send(conn, reply)
    except (KeyboardInterrupt, EOFError, BrokenPipeError, ConnectionResetError):
        pass  # stopped, or the parent is gone
    finally:
        # done (told to stop, or the parent is gone): a SIGTERM from now on (the parent's
        # death, seen after its pipe closed; a shutdown) ends the process quietly instead of
        # raising in its exit handlers. A plain store: no signal handler runs in between
        _done = True


class RemoteTraceback(Exception):
    """The traceback of an unexpected error in a worker (chained to the raised error)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass
class _Slot:
    process: Any
    conn: Connection
    job: tuple[int, Any] | None = None  # (position, payload) running now


def describe_exit(exitcode: int | None) -> str:
    """``"killed by SIGKILL"``, ``"exit status 1"``."""
    if exitcode is None:
        return "lost"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        hint = ", out of memory?" if -exitcode == signal.SIGKILL else ""
        return f"killed by {name}{hint}"
    return f"exit status {exitcode}"


class WorkerPool:
    """``num_workers`` spawned processes, each running one job at a time.

    Args:
        num_workers: processes at most (started when there is a job for them).
        initializer, initargs: called once in each new worker (picklable).
        task: called in a worker with a job's payload; its return value is the result.
        max_tries: tries of a job whose worker died, before :class:`UserError`.
        window: jobs may start only within this many positions of the first unfinished one
            (bounds the results the caller holds back to keep order).
        describe: names a payload in messages, e.g. ``"attempt 3"``.
        warn: where "worker died, running it again" lines go.
    """

    def __init__(
        self,
        num_workers: int,
        initializer: Callable[..., None],
        initargs: tuple,
        task: Callable[[Any], Any],
        max_tries: int = MAX_TRIES,
        window: int | None = None,
        describe: Callable[[Any], str] = lambda payload: "a job",
        warn: Callable[[str], None] = lambda line: print(line, file=sys.stderr),
    ) -> None:
        if num_workers < 1:
            raise ValueError(f"num_workers must be at least 1, got {num_workers}")
        self.num_workers = num_workers
        self.initializer, self.initargs, self.task = initializer, initargs, task
        self.max_tries = max_tries
        self.window = window if window is not None else 4 * num_workers
        self.describe, self.warn = describe, warn
        self._ctx = mp.get_context("spawn")
        self._slots: list[_Slot] = []
        self._tries: dict[int, int] = {}

    def _start(self) -> _Slot:
        here, there = self._ctx.Pipe(duplex=True)
        process = self._ctx.Process(
            target=_worker_main,
            args=(there, os.getpid(), self.initializer, self.initargs, self.task),
            daemon=True,
        )
        with _sigint_blocked():
            process.start()
        there.close()
        slot = _Slot(process, here)
        self._slots.append(slot)
        return slot

    def results(self, payloads: Iterable[Any]) -> Iterator[tuple[int, Any]]:
        """Run every payload; yields ``(position, result)`` as each finishes.

        Raises:
            UserError: a job's workers died ``max_tries`` times, or the job raised one.
            Exception: whatever a job raised (with the worker's traceback chained).
        """
        self._source = iter(payloads)
        self._next = 0  # position of the next payload from the source
        self._exhausted = False
        retry: deque[tuple[int, Any]] = deque()
        unfinished: set[int] = set()
        while True:
            self._assign(retry, unfinished)
            busy = [slot for slot in self._slots if slot.job is not None]
            if not busy:
                return
            objects = [slot.conn for slot in busy] + [slot.process.sentinel for slot in busy]
            wait(objects, timeout=POLL_S)
            for slot in busy:
                reply = self._reply(slot)
                if reply is not None:
                    kind, position, value, text = reply
                    if kind == "error":
                        self._raise(value, text)
                    slot.job = None
                    unfinished.discard(position)
                    yield position, value
                elif not slot.process.is_alive():
                    retry.appendleft(self._lost(slot))

    def _take(self, unfinished: set[int]) -> tuple[int, Any] | None:
        """The next job from the source, None when used up or outside the window."""
        if self._exhausted:
            return None
        if unfinished and self._next - min(unfinished) >= self.window:
            return None
        try:
            payload = next(self._source)
        except StopIteration:
            self._exhausted = True
            return None
        job = (self._next, payload)
        self._next += 1
        unfinished.add(job[0])
        return job

    def _assign(self, retry: deque, unfinished: set[int]) -> None:
        """Give jobs to idle workers (retries first), starting workers as needed."""
        for slot in [s for s in self._slots if s.job is None and not s.process.is_alive()]:
            self._discard(slot)
        while True:
            idle = [slot for slot in self._slots if slot.job is None]
            if not idle and len(self._slots) >= self.num_workers:
                return
            job = retry.popleft() if retry else self._take(unfinished)
            if job is None:
                return
            slot = idle[0] if idle else self._start()
            slot.job = job
            with contextlib.suppress(OSError):  # a dead worker is seen at the next wait
                slot.conn.send(job)

    def _reply(self, slot: _Slot) -> tuple | None:
        try:
            if not slot.conn.poll():
                return None
            return slot.conn.recv()
        except (EOFError, OSError):
            return None

    def _lost(self, slot: _Slot) -> tuple[int, Any]:
        """Account for a worker that died running its job; returns the job to run again."""
        assert slot.job is not None
        job, pid = slot.job, slot.process.pid
        slot.process.join(timeout=1.0)
        how = describe_exit(slot.process.exitcode)
        self._discard(slot)
        tries = self._tries[job[0]] = self._tries.get(job[0], 1) + 1
        name = self.describe(job[1])
        if tries > self.max_tries:
            raise UserError(
                f"{name}: the worker process running it died in each of {self.max_tries} "
                f"tries (last: {how}); check memory use and rerun the same command to continue"
            )
        self.warn(
            f"warning: worker process {pid} running {name} died ({how}); running {name} "
            f"again (try {tries} of {self.max_tries})"
        )
        return job

    def _discard(self, slot: _Slot) -> None:
        with contextlib.suppress(OSError):
            slot.conn.close()
        self._slots.remove(slot)

    @staticmethod
    def _raise(error: BaseException, text: str) -> None:
        if text and not isinstance(error, UserError):
            raise error from RemoteTraceback(f"\n\n--- in the worker process ---\n{text}")
        raise error

    def shutdown(self, cancel: bool = True) -> list[tuple[int, Any]]:
        """Stop every worker: idle ones are told to stop, busy ones get SIGTERM (``cancel``)
        and discard their partial files. Returns results that arrived meanwhile."""
        late: list[tuple[int, Any]] = []
        for slot in self._slots:
            with contextlib.suppress(OSError, ValueError):
                if slot.job is None:
                    slot.conn.send(None)
                elif cancel and slot.process.is_alive():
                    os.kill(slot.process.pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_WAIT_S
        for slot in self._slots:
            slot.process.join(timeout=max(0.0, deadline - time.monotonic()))
            if slot.process.is_alive():
                slot.process.kill()
                slot.process.join()
        for slot in self._slots:
            while True:
                reply = self._reply(slot)
                if reply is None:
                    break
                if reply[0] == "ok":
                    late.append((reply[1], reply[2]))
        for slot in list(self._slots):
            self._discard(slot)
        return late
