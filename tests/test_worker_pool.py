"""The local worker pool (``worker_pool``): results with their positions, errors raised here
with the worker's traceback, workers that die, the caller as one of the workers (``here``:
a process slow to start takes fewer jobs), and no worker outliving the pool.

The runners are tiny stand-ins in a module written for the test (spawned workers import it
through sys.path); who waits for whom is signalled with files, so no outcome depends on
timing. Signals and the parent's death: ``test_worker_pool_signals.py``."""

from __future__ import annotations

import multiprocessing
import os
import textwrap
import uuid
from functools import partial

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.worker_pool import RemoteTraceback, WorkerPool, describe_exit, in_order

RUNNER_MODULE = """
import math
import os
import signal
import time
import warnings
from pathlib import Path

from trossen_arm_mujoco.errors import UserError


class Calls:  # a builtin as a runner
    def __init__(self, name):
        self.fn = {"abs": abs, "sqrt": math.sqrt, "exit": os._exit, "warn": warnings.warn}[name]

    def run(self, payload):
        return self.fn(payload)

    def close(self):
        pass


def _wait_for(test, what):
    end = time.monotonic() + 120
    while not test():
        if time.monotonic() > end:
            raise TimeoutError(what)
        time.sleep(0.05)


class Runner:
    def __init__(self, parent_pid, folder, mode, n):
        self.parent = os.getpid() == parent_pid
        self.folder, self.mode, self.n, self.ran = Path(folder), mode, n, 0
        if mode == "parent_waits" and self.parent:  # until the workers ran every job
            _wait_for(lambda: len(list(self.folder.glob("ran_*"))) >= n, "the workers")
        if mode == "workers_wait" and not self.parent:  # until the caller ran every one
            _wait_for(lambda: (self.folder / "caller_done").exists(), "the caller")
        if not self.parent and mode == "worker_user_error":
            (self.folder / "failed").touch()
            raise UserError("no such policy in the worker")
        if mode in ("worker_raises", "worker_dies", "worker_user_error"):
            if self.parent:  # the worker starts first, then the caller
                name = "failed" if mode == "worker_user_error" else "built"
                _wait_for(lambda: (self.folder / name).exists(), "a worker")
            else:
                (self.folder / "built").touch()

    def run(self, index):
        if not self.parent:
            if self.mode == "worker_raises":
                raise ValueError(f"boom at episode {index}")
            if self.mode == "worker_dies":
                os.kill(os.getpid(), signal.SIGKILL)
            (self.folder / f"ran_{index}").touch()
        else:
            self.ran += 1
            if self.mode == "workers_wait" and self.ran == self.n:
                (self.folder / "caller_done").touch()
            if self.mode in ("worker_raises", "worker_dies", "worker_user_error"):
                time.sleep(0.2)  # the worker's message arrives meanwhile
        return index, os.getpid()

    def close(self):
        pass


class Real:  # a real EpisodeRunner in the workers only (the caller waits until they ran all)

    def __init__(self, parent_pid, folder, n, settings):
        from trossen_arm_mujoco.eval.runner import EpisodeRunner

        self.folder, self.runner = Path(folder), None
        if os.getpid() == parent_pid:
            _wait_for(lambda: len(list(self.folder.glob("ran_*"))) >= n, "the workers")
        else:
            self.runner = EpisodeRunner(settings, 1)

    def run(self, index):
        result = self.runner.run(index)
        (self.folder / f"ran_{index}").touch()
        return result, os.getpid()

    def close(self):
        if self.runner is not None:
            self.runner.close()
"""


@pytest.fixture
def runners(tmp_path, monkeypatch):
    """``runners(mode, n)``: a stand-in runner's factory (picklable: a partial of a class in
    a module the workers can import); ``runners.calls(name)``: a builtin's."""
    name = f"pool_runner_{uuid.uuid4().hex[:8]}"
    folder = tmp_path / "mod"
    folder.mkdir()
    (folder / f"{name}.py").write_text(textwrap.dedent(RUNNER_MODULE), encoding="utf-8")
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("PYTHONPATH", str(folder))
    module = __import__(name)
    signals = tmp_path / "signals"
    signals.mkdir()

    def make(mode, n, settings=None):
        if mode == "real":
            return partial(module.Real, os.getpid(), str(signals), n, settings)
        return partial(module.Runner, os.getpid(), str(signals), mode, n)

    make.calls = lambda fn: partial(module.Calls, fn)
    return make


def run_here(pool: WorkerPool, n: int) -> list:
    """Jobs 0..n-1 on the pool and this process, in order; the pool shut down after."""
    try:
        return list(in_order(pool.results(range(n), here=True)))
    finally:
        pool.shutdown()
        assert multiprocessing.active_children() == []


# -- the workers alone ---------------------------------------------------------------------
def test_every_result_comes_back_with_its_position(runners):
    pool = WorkerPool(2, runners.calls("abs"))
    try:
        results = dict(pool.results([-3, 4, -5, 6, -7]))
    finally:
        assert pool.shutdown() == []
    assert results == {0: 3, 1: 4, 2: 5, 3: 6, 4: 7}
    assert multiprocessing.active_children() == []


def test_an_error_in_a_job_is_raised_with_the_worker_traceback(runners):
    pool = WorkerPool(1, runners.calls("sqrt"))
    try:
        with pytest.raises(ValueError, match="math domain error") as exc_info:
            list(pool.results([4.0, -1.0]))
    finally:
        pool.shutdown()
    assert isinstance(exc_info.value.__cause__, RemoteTraceback)
    assert "in the worker process" in str(exc_info.value.__cause__)
    assert "Traceback" in str(exc_info.value.__cause__)


def test_a_job_whose_worker_dies_every_time_ends_in_one_line(runners):
    warnings: list[str] = []
    pool = WorkerPool(
        1, runners.calls("exit"), warn=warnings.append, describe=lambda code: f"job {code}"
    )
    try:
        with pytest.raises(UserError) as exc_info:
            list(pool.results([7]))
    finally:
        pool.shutdown()
    assert str(exc_info.value) == (
        "job 7: the worker process running it died in each of 3 tries (last: exit status 7); "
        "check memory use and rerun the same command to continue"
    )
    assert len(warnings) == 2
    assert warnings[0].endswith("died (exit status 7); running job 7 again (try 2 of 3)")
    assert multiprocessing.active_children() == []


def test_describe_exit():
    assert describe_exit(-9) == "killed by SIGKILL, out of memory?"
    assert describe_exit(-15) == "killed by SIGTERM"
    assert describe_exit(3) == "exit status 3"


def test_a_warning_in_a_worker_prints_as_one_note_line(runners, capfd):
    pool = WorkerPool(1, runners.calls("warn"))
    try:
        assert dict(pool.results(["the light is low"])) == {0: None}
    finally:
        assert pool.shutdown() == []
    err = capfd.readouterr().err
    assert "note: the light is low" in err
    assert "UserWarning" not in err and "warnings.warn" not in err


def test_in_order_holds_back_later_results():
    assert list(in_order([(2, "c"), (0, "a"), (1, "b"), (3, "d")])) == [
        (0, "a"),
        (1, "b"),
        (2, "c"),
        (3, "d"),
    ]


# -- this process as one of the workers (here=True) ----------------------------------------
def test_workers_take_every_job_while_the_caller_is_slow_to_start(runners):
    out = run_here(WorkerPool(2, runners("parent_waits", 6)), 6)
    assert [i for i, _ in out] == list(range(6))
    assert [r[0] for _, r in out] == list(range(6))  # each result is its own job's
    pids = {r[1] for _, r in out}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2


def test_the_caller_takes_every_job_while_the_workers_are_slow_to_start(runners):
    out = run_here(WorkerPool(1, runners("workers_wait", 5)), 5)
    assert [r for _, r in out] == [(i, os.getpid()) for i in range(5)]


def test_a_user_error_in_a_worker_is_one_user_error_in_the_caller(runners):
    with pytest.raises(UserError, match="no such policy in the worker"):
        run_here(WorkerPool(1, runners("worker_user_error", 8)), 8)


def test_another_error_in_a_worker_keeps_its_type_and_traceback(runners):
    with pytest.raises(ValueError, match="boom at episode") as caught:
        run_here(WorkerPool(1, runners("worker_raises", 8)), 8)
    assert isinstance(caught.value.__cause__, RemoteTraceback)
    assert "Traceback" in str(caught.value.__cause__)


def test_a_job_that_kills_its_worker_runs_again_in_a_new_one_never_here(runners):
    """The caller runs the other jobs; the one whose worker died goes to new workers only,
    each of which dies too: one line after ``max_tries``."""
    warnings: list[str] = []
    pool = WorkerPool(
        1,
        runners("worker_dies", 8),
        describe=lambda index: f"episode {index}",
        warn=warnings.append,
        advice="rerun with fewer --num_workers",
    )
    with pytest.raises(UserError, match="worker process running it died") as caught:
        run_here(pool, 8)
    assert str(caught.value).endswith(
        "died in each of 3 tries (last: killed by SIGKILL, out of memory?); "
        "rerun with fewer --num_workers"
    )
    assert len(warnings) == 2 and "(try 3 of 3)" in warnings[1]


def test_a_consumer_that_stops_early_ends_the_workers(runners):
    pool = WorkerPool(1, runners("parent_waits", 4))
    results = in_order(pool.results(range(4), here=True))
    assert next(results)[0] == 0
    results.close()
    pool.shutdown()
    assert multiprocessing.active_children() == []


def test_a_spawned_worker_scores_an_episode_as_this_process_does(runners, tmp_path):
    """The scripted policy, short episodes: the scores of episodes run in a spawned worker
    (with a worker's thread share) equal those run here, field by field."""
    from dataclasses import asdict

    from trossen_arm_mujoco.eval.runner import EpisodeRunner, EvalSettings

    settings = EvalSettings(
        policy="scripted",
        num_episodes=2,
        seed=5,
        episode_length=120,
        output_dir=str(tmp_path / "out"),
    )
    here = EpisodeRunner(settings)
    try:
        expected = [asdict(here.run(i)[0]) for i in range(2)]
    finally:
        here.close()
    out = run_here(WorkerPool(1, runners("real", 2, settings)), 2)
    assert all(pid != os.getpid() for _, (_, pid) in out)
    assert [asdict(score) for _, ((score, _), _) in out] == expected
