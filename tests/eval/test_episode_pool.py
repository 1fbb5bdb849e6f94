"""The local eval workers (``eval.episode_pool``): the caller is one of the workers, episodes
are handed out one at a time (a process slow to start takes fewer), results come in order,
a worker's error is raised in the caller, and no worker outlives the run.

The runners are tiny stand-ins (episode i gives (i, pid)) in a module written for the test
(spawned workers import it through sys.path); who waits for whom is signalled with files,
so no outcome depends on timing."""

from __future__ import annotations

import multiprocessing
import os
import textwrap
import uuid
from functools import partial

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.episode_pool import WORKER_DIED, WorkerError, run_episodes

RUNNER_MODULE = """
import os
import signal
import time
from pathlib import Path

from trossen_arm_mujoco.errors import UserError


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
        if mode == "parent_waits" and self.parent:  # until the workers ran every episode
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
def make_runner(tmp_path, monkeypatch):
    """``make_runner(mode, n)``: the stand-in runner's factory (picklable: a partial of a
    class in a module the workers can import)."""
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

    return make


def test_workers_take_every_episode_while_the_caller_is_slow_to_start(make_runner):
    out = list(run_episodes(make_runner("parent_waits", 6), 6, 3))
    assert [i for i, _ in out] == list(range(6))
    assert [r[0] for _, r in out] == list(range(6))  # each result is its own episode's
    pids = {r[1] for _, r in out}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2
    assert multiprocessing.active_children() == []


def test_the_caller_takes_every_episode_while_the_workers_are_slow_to_start(make_runner):
    out = list(run_episodes(make_runner("workers_wait", 5), 5, 2))
    assert [r for _, r in out] == [(i, os.getpid()) for i in range(5)]
    assert multiprocessing.active_children() == []


def test_a_user_error_in_a_worker_is_one_user_error_in_the_caller(make_runner):
    with pytest.raises(UserError, match="no such policy in the worker"):
        list(run_episodes(make_runner("worker_user_error", 8), 8, 2))
    assert multiprocessing.active_children() == []


def test_another_error_in_a_worker_keeps_its_type_and_traceback(make_runner):
    with pytest.raises(ValueError, match="boom at episode") as caught:
        list(run_episodes(make_runner("worker_raises", 8), 8, 2))
    assert isinstance(caught.value.__cause__, WorkerError)
    assert "Traceback" in str(caught.value.__cause__)
    assert multiprocessing.active_children() == []


def test_a_worker_that_dies_is_one_user_error(make_runner):
    with pytest.raises(UserError, match="worker died") as caught:
        list(run_episodes(make_runner("worker_dies", 8), 8, 2))
    assert str(caught.value) == WORKER_DIED
    assert multiprocessing.active_children() == []


def test_a_consumer_that_stops_early_ends_the_workers(make_runner):
    episodes = run_episodes(make_runner("parent_waits", 4), 4, 2)
    assert next(episodes)[0] == 0
    episodes.close()
    assert multiprocessing.active_children() == []


def test_a_spawned_worker_scores_an_episode_as_this_process_does(make_runner, tmp_path):
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
    out = list(run_episodes(make_runner("real", 2, settings), 2, 2))
    assert all(pid != os.getpid() for _, (_, pid) in out)
    assert [asdict(score) for _, ((score, _), _) in out] == expected
    assert multiprocessing.active_children() == []
