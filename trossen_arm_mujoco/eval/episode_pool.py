"""Episodes 0..n-1 run by this process and ``workers - 1`` spawned ones, handed out one at a
time, results yielded in episode order.

Each process builds its runner once (``make_runner()``: anything with ``run(index)`` and
``close()``) and then takes the next unclaimed episode index from a shared counter until none
is left, so a process slow to start takes fewer episodes. Children are spawned, never forked,
and send each result (or the error that stopped them) through a queue.

Docs: docs/cli/eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import queue
import sys
import traceback
from collections.abc import Callable, Iterator
from typing import Any, Protocol

from trossen_arm_mujoco.errors import UserError

__all__ = ["WORKER_DIED", "EpisodeSource", "WorkerError", "run_episodes"]

#: The one line when a spawned worker ends without sending its episode's result.
WORKER_DIED = "an evaluation worker died (out of memory?); rerun with fewer --num_workers"
#: Seconds between checks that the spawned workers are alive while waiting for a result.
POLL_S = 0.5


class EpisodeSource(Protocol):
    """What each process builds once and runs episodes with."""

    def run(self, index: int) -> Any:
        """The result of episode ``index`` (picklable)."""

    def close(self) -> None:
        """Release what the runner holds."""


class WorkerError(Exception):
    """The traceback text of an error raised in a spawned worker (set as the ``__cause__``
    of the error raised again in the caller)."""


def _claim(counter: Any, n: int) -> int | None:
    """The next unclaimed index below ``n`` (claimed now), or None when none is left."""
    with counter.get_lock():
        index = counter.value
        if index >= n:
            return None
        counter.value = index + 1
        return index


def _error_message(index: int | None, exc: BaseException) -> tuple[Any, ...]:
    """The queue message of an error: a UserError as its text (one line in the caller),
    anything else pickled with its traceback text (or as a RuntimeError naming it when it
    does not pickle)."""
    if isinstance(exc, UserError):
        return ("user_error", index, str(exc))
    text = "".join(traceback.format_exception(exc))
    try:
        payload = pickle.dumps(exc)
    except Exception:
        payload = pickle.dumps(RuntimeError(f"{type(exc).__name__}: {exc}"))
    return ("error", index, payload, text)


def _child(make_runner: Callable[[], EpisodeSource], counter: Any, results: Any, n: int) -> None:
    """A spawned worker: build the runner, run claimed episodes, send each result (and
    stop early when the caller is gone, killed without its cleanup)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    caller = multiprocessing.parent_process()
    runner = None
    try:
        runner = make_runner()
        while (caller is None or caller.is_alive()) and (index := _claim(counter, n)) is not None:
            try:
                results.put(("result", index, runner.run(index)))
            except BaseException as exc:
                results.put(_error_message(index, exc))
                raise
    except KeyboardInterrupt:  # the caller was interrupted too and says so
        pass
    except BaseException as exc:
        if runner is None:  # the runner could not be built: its error, once
            results.put(_error_message(None, exc))
    finally:
        if runner is not None:
            runner.close()
        results.close()
        results.join_thread()  # every result is in the pipe
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(0)  # skip the teardown of torch and LeRobot (nothing else is pending)


def _raise(message: tuple[Any, ...]) -> None:
    """Raise again in the caller the error a child sent."""
    if message[0] == "user_error":
        raise UserError(message[2])
    exc = pickle.loads(message[2])
    raise exc from WorkerError(message[3])


def run_episodes(
    make_runner: Callable[[], EpisodeSource], n: int, workers: int
) -> Iterator[tuple[int, Any]]:
    """``(index, make_runner().run(index))`` for index 0..n-1 in order, over this process
    and ``workers - 1`` spawned ones (``make_runner`` is pickled to them: a module-level
    callable or a ``functools.partial`` of one). The spawned ones inherit this process's
    environment as it is when this generator starts. A worker's UserError is one UserError
    here; another error is raised again here with the worker's traceback as its cause; a
    worker ending without its result is a UserError (``WORKER_DIED``).

    Args:
        make_runner: builds a process's runner (``run(index)``, ``close()``); pickled to the spawned
            workers.
        n: the number of episodes.
        workers: the number of processes, this one included.

    Raises:
        UserError: a worker's UserError, or a worker that ended without its result.
    """
    ctx = multiprocessing.get_context("spawn")
    counter, results = ctx.Value("i", 0), ctx.Queue()
    children = [
        ctx.Process(target=_child, args=(make_runner, counter, results, n), daemon=True)
        for _ in range(max(0, workers - 1))
    ]
    for child in children:
        child.start()
    done: dict[int, Any] = {}
    runner = None
    try:
        runner = make_runner()  # while the children start
        for index in range(n):
            while index not in done:
                _next_result(runner, counter, results, children, done, n)
            yield index, done.pop(index)
    finally:
        with counter.get_lock():
            counter.value = n  # nothing more to claim
        try:
            if runner is not None:
                runner.close()
        finally:
            _stop(children, results)


def _next_result(
    runner: EpisodeSource,
    counter: Any,
    results: Any,
    children: list[Any],
    done: dict[int, Any],
    n: int,
) -> None:
    """One step of the caller: take every result that arrived (and return); else run the
    next unclaimed episode here, or, when none is left, wait for the children's."""
    took = False
    while True:
        try:
            message = results.get_nowait()
        except queue.Empty:
            break
        _take(message, done)
        took = True
    if took:
        return
    if (index := _claim(counter, n)) is not None:
        done[index] = runner.run(index)
        return
    try:
        _take(results.get(timeout=POLL_S), done)
    except queue.Empty:
        if any(c.exitcode not in (None, 0) for c in children) or all(
            c.exitcode is not None for c in children
        ):
            try:  # a result sent just before its sender ended
                _take(results.get(timeout=POLL_S), done)
            except queue.Empty:
                raise UserError(WORKER_DIED) from None


def _take(message: tuple[Any, ...], done: dict[int, Any]) -> None:
    if message[0] == "result":
        done[message[1]] = message[2]
    else:
        _raise(message)


def _stop(children: list[Any], results: Any) -> None:
    """End the children now: after a complete run every result is in (one still starting
    or closing its runner has nothing left to give); after an error, an interruption or a
    consumer that stopped early their episodes are not wanted."""
    for child in children:
        if child.is_alive():
            child.terminate()
        child.join(timeout=10)
    results.close()
    results.cancel_join_thread()
