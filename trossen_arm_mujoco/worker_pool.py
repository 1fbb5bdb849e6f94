"""The package's one pool of local worker processes (``record`` and ``eval --num_workers N``).

:class:`WorkerPool` spawns its workers, each building its runner once (``make_runner()``:
``run(payload)``, ``close()``) and then running one job at a time, handed out when it is
free; :meth:`WorkerPool.results` yields ``(position, result)`` as each finishes
(:func:`in_order` puts them in order), with ``here=True`` running jobs in this process too.
A worker that dies loses only its job, which runs again in a new one (``max_tries`` in all);
a job's error is raised here. Ctrl-C and SIGTERM are the caller's: :meth:`WorkerPool.shutdown`
stops the workers (a busy one discards its partial file); a worker outlives no parent.

Docs: docs/cli/record.md, docs/cli/eval.md; the details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import queue
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
from typing import Any, Protocol

from trossen_arm_mujoco.errors import UserError, show_warning_as_note
from trossen_arm_mujoco.processes import parent_death_signal
from trossen_arm_mujoco.stopping import STOP_SIGNALS, redeliver_if_in_finalizer

__all__ = [
    "MAX_TRIES",
    "PARENT_POLL_S",
    "POLL_S",
    "STOP_WAIT_S",
    "RemoteTraceback",
    "Runner",
    "WorkerPool",
    "describe_exit",
    "in_order",
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


class Runner(Protocol):
    """What each process builds once (``make_runner()``) and runs jobs with."""

    def run(self, payload: Any) -> Any:
        """The result of one job (picklable)."""

    def close(self) -> None:
        """Release what the runner holds."""


# -- in a worker --------------------------------------------------------------------------
def _raise_interrupt(signum: int, frame: Any) -> None:
    """SIGTERM in a worker: the first raises ``KeyboardInterrupt`` while it runs jobs (so
    that its partial file is discarded); more while it stops are ignored, so that they
    cannot cut its cleanup short; once it is done (:data:`_done`) the signal takes its
    default action, so that a late one ends the process at once and in silence.

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


def _send(conn: Connection, message: tuple) -> None:
    try:
        conn.send(message)
    except (TypeError, AttributeError, ValueError, RuntimeError, mp.ProcessError):
        kind, position, error, text = message  # not picklable
        conn.send((kind, position, RuntimeError(f"{type(error).__name__}: {error}"), text))


def _worker_main(conn: Connection, parent: int, make_runner: Callable[[], Runner]) -> None:
    """Body of one worker process: build the runner, say it is ready, then run jobs until
    told to stop (or the parent is gone); see the design notes for signals. It leaves with
    ``os._exit`` once its runner is closed, skipping the interpreter's teardown (torch's
    takes a second), which the caller would wait for."""
    global _done, _stopping
    runner = None
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if hasattr(signal, "pthread_sigmask"):  # blocked by the parent while it started us
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        signal.signal(signal.SIGTERM, _raise_interrupt)
        _die_with_parent(parent)
        # warnings raised in a worker print as the parent's do: one plain "note:" line
        warnings.showwarning = show_warning_as_note
        try:
            runner = make_runner()
        except Exception as exc:
            _send(conn, ("error", None, exc, traceback.format_exc()))
            return
        conn.send(("ready", None, None, ""))
        while True:
            _stopping = False  # a job that swallowed an interrupt ran to its end: not stopping
            message = conn.recv()
            if message is None:
                return
            position, payload = message
            try:
                reply = ("ok", position, runner.run(payload), "")
            except Exception as exc:
                reply = ("error", position, exc, traceback.format_exc())
            _send(conn, reply)
    except (KeyboardInterrupt, EOFError, BrokenPipeError, ConnectionResetError):
        pass  # stopped, or the parent is gone
    except Exception:  # a bug here: said before the worker leaves
        traceback.print_exc()
    finally:
        # done: a SIGTERM from now on (the parent's death, seen after its pipe closed; a
        # shutdown) ends the process at once instead of raising in its cleanup
        _done = True
        with contextlib.suppress(Exception):
            if runner is not None:
                runner.close()
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(0)


# -- in the caller ------------------------------------------------------------------------
class RemoteTraceback(Exception):
    """The traceback of an unexpected error in a worker (chained to the raised error)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def describe_exit(exitcode: int | None) -> str:
    """``"killed by SIGKILL, out of memory?"``, ``"exit status 1"``."""
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


def in_order(results: Iterable[tuple[int, Any]]) -> Iterator[tuple[int, Any]]:
    """``(position, result)`` pairs that come as they finish, yielded in position order
    (0, 1, 2, ...; later ones held back until the earlier ones came)."""
    held: dict[int, Any] = {}
    following = 0
    for position, result in results:
        held[position] = result
        while following in held:
            yield following, held.pop(following)
            following += 1


@contextlib.contextmanager
def _signals_blocked(signums: set[int]) -> Iterator[None]:
    """This thread's signal mask is ``signums`` for the block (a process started meanwhile
    inherits it, through ``exec`` too)."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_SETMASK, signums)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@dataclass
class _Slot:
    process: Any
    conn: Connection
    ready: bool = False  # its runner is built: it may take jobs
    job: tuple[int, Any] | None = None  # (position, payload) running now


class WorkerPool:
    """``num_workers`` spawned processes, each running one job at a time.

    The workers are started, fed and watched by a thread of this process (the
    dispatcher), so they take jobs while this process runs its own (``here``) or builds its
    runner; the dispatcher hands results to :meth:`results` in this process's main thread,
    which raises errors and takes Ctrl-C.

    Args:
        num_workers: spawned processes (all started at once).
        make_runner: builds a process's runner, once (picklable: a module-level callable or a
            ``functools.partial`` of one).
        max_tries: tries of a job whose worker died (or of starting a worker), before
            :class:`UserError`.
        window: jobs may start only within this many positions of the first unfinished one
            (bounds the results the caller holds back to keep order); None: no bound.
        describe: names a payload in messages, e.g. ``"attempt 3"``.
        warn: where "worker died, running it again" lines go (called by :meth:`results`).
        advice: the end of the one line when workers died ``max_tries`` times.
    """

    def __init__(
        self,
        num_workers: int,
        make_runner: Callable[[], Runner],
        max_tries: int = MAX_TRIES,
        window: int | None = None,
        describe: Callable[[Any], str] = lambda payload: "a job",
        warn: Callable[[str], None] = lambda line: print(line, file=sys.stderr),
        advice: str = "check memory use and rerun the same command to continue",
    ) -> None:
        if num_workers < 1:
            raise ValueError(f"num_workers must be at least 1, got {num_workers}")
        self.num_workers = num_workers
        self.make_runner = make_runner
        self.max_tries = max_tries
        self.window = window
        self.describe, self.warn, self.advice = describe, warn, advice
        self._ctx = mp.get_context("spawn")
        self._slots: list[_Slot] = []
        self._lock = threading.Lock()  # the job source and its bookkeeping
        self._tries: dict[int, int] = {}
        self._start_deaths = 0
        self._retry: deque[tuple[int, Any]] = deque()
        self._unfinished: set[int] = set()
        self._source: Iterator[Any] = iter(())
        self._next = 0  # position of the next payload from the source
        self._exhausted = False
        self._inbox: queue.SimpleQueue[tuple] = queue.SimpleQueue()  # dispatcher -> caller
        self._failed = False  # an error was handed over: the run ends, no job starts
        self._stop = threading.Event()
        self._wake_r, self._wake_w = mp.Pipe(duplex=False)
        self._thread: threading.Thread | None = None
        self._cancel = True
        self._late: list[tuple[int, Any]] = []

    @property
    def pids(self) -> list[int]:
        """The process ids of the workers started and not yet seen dead."""
        return [slot.process.pid for slot in list(self._slots)]

    # -- the caller's side --------------------------------------------------------------
    def results(self, payloads: Iterable[Any], here: bool = False) -> Iterator[tuple[int, Any]]:
        """Run every payload; yields ``(position, result)`` as each finishes. ``here``: this
        process builds its runner too (while the workers start) and runs jobs whenever no
        result is waiting; it never takes a job whose worker died.

        Raises:
            UserError: a job's workers died ``max_tries`` times, or a runner raised one.
            Exception: whatever a runner raised (a worker's traceback chained to it).
        """
        if self._thread is not None:
            raise RuntimeError("WorkerPool.results runs once")
        self._source = iter(payloads)
        self._thread = threading.Thread(target=self._dispatch, name="worker-pool", daemon=True)
        self._thread.start()
        runner = None
        try:
            if here:
                runner = self.make_runner()
            while True:
                yield from self._arrived()
                if self._finished():
                    yield from self._arrived()  # all in: they came before the bookkeeping
                    return
                job = self._claim(retries=False) if runner is not None else None
                if job is not None:
                    result = runner.run(job[1])
                    with self._lock:
                        self._unfinished.discard(job[0])
                    yield job[0], result
                    continue
                try:
                    message = self._inbox.get(timeout=POLL_S)
                except queue.Empty:
                    if not self._thread.is_alive():  # it hands over its own errors first
                        raise RuntimeError("the worker pool's dispatcher ended") from None
                    continue
                yield from self._take(message)
        finally:
            if runner is not None:
                runner.close()

    def _arrived(self) -> Iterator[tuple[int, Any]]:
        """Every result the dispatcher handed over; raises the first error among them."""
        while True:
            try:
                message = self._inbox.get_nowait()
            except queue.Empty:
                return
            yield from self._take(message)

    def _take(self, message: tuple) -> Iterator[tuple[int, Any]]:
        kind, position, value, text = message
        if kind == "ok":
            yield position, value
        elif kind == "warn":
            self.warn(value)
        else:
            self._raise(value, text)

    @staticmethod
    def _raise(error: BaseException, text: str) -> None:
        if text and not isinstance(error, UserError):
            raise error from RemoteTraceback(f"\n\n--- in the worker process ---\n{text}")
        raise error

    def _finished(self) -> bool:
        with self._lock:
            return self._exhausted and not self._retry and not self._unfinished

    def _claim(self, retries: bool) -> tuple[int, Any] | None:
        """The next job (a retry first, when ``retries``); None when there is none now: the
        source used up or the window full."""
        with self._lock:
            if self._failed:
                return None
            if retries and self._retry:
                return self._retry.popleft()
            if self._exhausted:
                return None
            if (
                self.window is not None
                and self._unfinished
                and self._next - min(self._unfinished) >= self.window
            ):
                return None
            try:
                payload = next(self._source)
            except StopIteration:
                self._exhausted = True
                return None
            job = (self._next, payload)
            self._next += 1
            self._unfinished.add(job[0])
            return job

    def shutdown(self, cancel: bool = True) -> list[tuple[int, Any]]:
        """Stop every worker: idle ones are told to stop, busy ones (``cancel``) and those
        still starting get SIGTERM (a busy one discards its partial file). Returns the
        results that arrived meanwhile, or that :meth:`results` did not yield."""
        late: list[tuple[int, Any]] = []
        if self._thread is None:
            return late
        self._cancel = cancel
        self._stop.set()
        with contextlib.suppress(OSError):
            self._wake_w.send_bytes(b"x")
        self._thread.join()
        self._wake_r.close()
        self._wake_w.close()
        while True:
            try:
                kind, position, value, _ = self._inbox.get_nowait()
            except queue.Empty:
                break
            if kind == "ok":
                late.append((position, value))
        return late + self._late

    # -- the dispatcher thread ----------------------------------------------------------
    def _dispatch(self) -> None:
        """Start the workers, feed them jobs, collect their replies, replace the dead; on
        :meth:`shutdown`, stop them. The workers' parent is this thread: the kernel's
        parent-death signal fires when it exits, so it exits only once they are stopped."""
        if hasattr(signal, "pthread_sigmask"):  # Ctrl-C, SIGTERM, ... go to the main thread
            signal.pthread_sigmask(signal.SIG_BLOCK, set(STOP_SIGNALS))
        try:
            with contextlib.suppress(Exception):
                # multiprocessing starts its resource tracker with the first process, and
                # unblocks SIGINT after that: started first, it leaves the mask alone
                from multiprocessing import resource_tracker

                resource_tracker.ensure_running()
            while not self._stop.is_set():
                self._staff()
                self._assign()
                busy = list(self._slots)
                objects = [s.conn for s in busy] + [s.process.sentinel for s in busy]
                wait([*objects, self._wake_r], timeout=POLL_S)
                for slot in busy:
                    self._collect(slot)
        except BaseException as exc:  # a bug here: the caller raises it
            self._hand_over(("error", None, exc, traceback.format_exc()))
        finally:
            self._late = self._stop_workers(self._cancel)

    def _hand_over(self, message: tuple) -> None:
        if message[0] == "error":
            with self._lock:
                self._failed = True
        self._inbox.put(message)

    def _staff(self) -> None:
        """Start workers up to ``num_workers`` while there is work for them."""
        with self._lock:
            work = not self._failed and (self._retry or not self._exhausted)
        while work and len(self._slots) < self.num_workers:
            self._start()

    def _start(self) -> _Slot:
        here, there = self._ctx.Pipe(duplex=True)
        process = self._ctx.Process(
            target=_worker_main, args=(there, os.getpid(), self.make_runner), daemon=True
        )
        # SIGINT blocked through the worker's start-up (imports included): a Ctrl-C then
        # cannot raise KeyboardInterrupt there; SIGTERM open: it ends a worker still starting
        with _signals_blocked({signal.SIGINT}):
            process.start()
        there.close()
        slot = _Slot(process, here)
        self._slots.append(slot)
        return slot

    def _assign(self) -> None:
        """Give jobs to the ready idle workers (retries first)."""
        for slot in self._slots:
            if not slot.ready or slot.job is not None:
                continue
            job = self._claim(retries=True)
            if job is None:
                return
            slot.job = job
            with contextlib.suppress(OSError):  # a dead worker is seen at the next wait
                slot.conn.send(job)

    def _collect(self, slot: _Slot) -> None:
        """Take a worker's reply, or account for its death."""
        reply = self._reply(slot)
        if reply is not None:
            kind, position = reply[0], reply[1]
            if kind == "ready":
                slot.ready = True
                return
            slot.job = None
            if kind == "error":
                self._hand_over(reply)
                return
            self._inbox.put(reply)  # before the bookkeeping: see results()
            with self._lock:
                self._unfinished.discard(position)
            return
        if slot.process.is_alive():
            return
        slot.process.join(timeout=1.0)
        how, pid, job = describe_exit(slot.process.exitcode), slot.process.pid, slot.job
        self._discard(slot)
        if self._failed:
            return
        if job is not None:
            self._lost(job, pid, how)
        elif not slot.ready:
            self._start_deaths += 1
            if self._start_deaths >= self.max_tries:
                self._hand_over(
                    (
                        "error",
                        None,
                        UserError(
                            f"the worker processes died while starting, {self._start_deaths} "
                            f"times (last: {how}); {self.advice}"
                        ),
                        "",
                    )
                )
            else:
                self._inbox.put(
                    ("warn", None, f"warning: worker process {pid} died while starting ({how})", "")
                )

    def _lost(self, job: tuple[int, Any], pid: int, how: str) -> None:
        """A worker died running ``job``: run it again, or give up after ``max_tries``."""
        tries = self._tries[job[0]] = self._tries.get(job[0], 1) + 1
        name = self.describe(job[1])
        if tries > self.max_tries:
            error = UserError(
                f"{name}: the worker process running it died in each of {self.max_tries} "
                f"tries (last: {how}); {self.advice}"
            )
            self._hand_over(("error", job[0], error, ""))
            return
        line = (
            f"warning: worker process {pid} running {name} died ({how}); running {name} "
            f"again (try {tries} of {self.max_tries})"
        )
        self._inbox.put(("warn", None, line, ""))
        with self._lock:
            self._retry.appendleft(job)

    @staticmethod
    def _reply(slot: _Slot) -> tuple | None:
        try:
            if not slot.conn.poll():
                return None
            return slot.conn.recv()
        except (EOFError, OSError):
            return None

    def _discard(self, slot: _Slot) -> None:
        with contextlib.suppress(OSError):
            slot.conn.close()
        self._slots.remove(slot)

    def _stop_workers(self, cancel: bool) -> list[tuple[int, Any]]:
        """Stop every worker (see :meth:`shutdown`); the results that came meanwhile."""
        late: list[tuple[int, Any]] = []
        for slot in self._slots:
            with contextlib.suppress(OSError, ValueError):
                if slot.ready and slot.job is None:
                    slot.conn.send(None)
                elif (cancel or not slot.ready) and slot.process.is_alive():
                    os.kill(slot.process.pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_WAIT_S
        for slot in self._slots:
            slot.process.join(timeout=max(0.0, deadline - time.monotonic()))
            if slot.process.is_alive():
                slot.process.kill()
                slot.process.join()
        for slot in self._slots:
            while (reply := self._reply(slot)) is not None:
                if reply[0] == "ok":
                    late.append((reply[1], reply[2]))
        for slot in list(self._slots):
            self._discard(slot)
        return late
