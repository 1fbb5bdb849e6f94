"""Workers of the local pool (``worker_pool``) end quietly whatever happens to their parent.

Each test runs a small program in its own process group and session, with the workers'
stderr (inherited from it) captured, so that anything a worker prints is seen even after
its parent is gone:

- a SIGTERM that reaches a worker after it stopped running jobs (the parent's death noticed
  first through its closed pipe, then signalled by the kernel) ends it without a traceback;
- Ctrl-C (SIGINT to the process group) while workers are still starting up: only the parent
  handles it;
- ``record --num_workers 2`` whose main process is killed with SIGKILL mid-run: its orphaned
  workers exit, print nothing, and every published episode is whole.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from trossen_arm_mujoco.data.reader import list_episodes, load_episode

REPO = Path(__file__).resolve().parents[2]
#: What a worker must never print.
NOISE = ("Traceback", "KeyboardInterrupt", "Exception ignored", "Error")


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped by its new parent, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def wait_gone(pids: list[int], timeout: float = 30.0) -> list[int]:
    """Wait until none of ``pids`` runs; returns those still running at the timeout."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and any(alive(p) for p in pids):
        time.sleep(0.05)
    return [p for p in pids if alive(p)]


class Program:
    """A Python program in its own session (process group), stdout and stderr piped; the
    lines of stdout are collected by a thread, stderr is read to its end (EOF comes once
    every process holding it, the workers included, has exited)."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        env = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, *args],
            cwd=cwd,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, prefix: str, count: int = 1, timeout: float = 120.0) -> list[str]:
        """The first ``count`` stdout lines starting with ``prefix`` (fails at the timeout)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            found = [line for line in list(self.lines) if line.startswith(prefix)]
            if len(found) >= count:
                return found[:count]
            if self.proc.poll() is not None and not self._reader.is_alive():
                break
            time.sleep(0.02)
        err = self.stderr(timeout=5.0)
        pytest.fail(f"no {count} line(s) {prefix!r} on stdout: {self.lines}\nstderr:\n{err}")

    def stderr(self, timeout: float = 60.0) -> str:
        """All of stderr, once every process holding it has exited."""
        assert self.proc.stderr is not None
        out: list[str] = []
        reader = threading.Thread(target=lambda: out.append(self.proc.stderr.read()))
        reader.daemon = True
        reader.start()
        reader.join(timeout)
        assert not reader.is_alive(), "stderr still open: a worker outlived the test"
        return out[0]

    def kill_group(self) -> None:
        """SIGKILL whatever is left of the process group (the test's own cleanup)."""
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait(timeout=10)


@pytest.fixture
def programs() -> Iterator[list[Program]]:
    made: list[Program] = []
    yield made
    for program in made:
        program.kill_group()


#: The program: a pool of ``workers`` workers over a module-level runner (a spawned worker
#: imports this file as ``__mp_main__``, so it can be pickled by reference).
POOL_PROGRAM = """
import os, signal, sys, threading, time
from functools import partial
if __name__ == "__mp_main__" and os.environ.get("SLOW_WORKER_START"):
    time.sleep(float(os.environ["SLOW_WORKER_START"]))  # a worker still starting up

from trossen_arm_mujoco import worker_pool
from trossen_arm_mujoco.worker_pool import WorkerPool

if __name__ == "__mp_main__" and os.environ.get("NO_PDEATHSIG"):
    worker_pool.parent_death_signal = lambda signum: None  # as where the kernel cannot signal it


class Runner:
    def __init__(self, mode):
        self.mode = mode

    def run(self, payload):
        os.write(1, f"job {payload} in {os.getpid()}\\n".encode())  # one write: lines stay whole
        if self.mode in ("orphan", "starting"):
            time.sleep(60)
        return payload

    def close(self):
        if self.mode == "late_sigterm":  # the worker is done (told to stop); a SIGTERM comes
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(2.0)
            print(f"worker {os.getpid()} survived a SIGTERM at exit", flush=True)


def say_started(pool, workers):
    while len(pool.pids) < workers:
        time.sleep(0.01)
    print("STARTED " + " ".join(map(str, pool.pids)), flush=True)


if __name__ == "__main__":
    mode, workers = sys.argv[1], int(sys.argv[2])
    pool = WorkerPool(workers, partial(Runner, mode))
    try:
        if mode == "starting":
            threading.Thread(target=say_started, args=(pool, workers), daemon=True).start()
        results = dict(pool.results(range(workers)))
        print("RESULTS", sorted(results), flush=True)
        print("PIDS " + " ".join(map(str, pool.pids)), flush=True)
    except KeyboardInterrupt:
        print("PARENT INTERRUPTED", flush=True)
    finally:
        pool.shutdown(cancel=True)
    print("PARENT DONE", flush=True)
"""


def test_a_sigterm_while_a_finished_worker_exits_is_quiet(
    tmp_path: Path, programs: list[Program]
) -> None:
    """Deterministic form of the race of an orphaned worker: its loop ends (its parent's
    pipe closed, or the parent told it to stop), then a SIGTERM arrives while it closes its
    runner; it used to raise ``KeyboardInterrupt`` in the exit handlers."""
    script = tmp_path / "pool_program.py"
    script.write_text(textwrap.dedent(POOL_PROGRAM))
    program = Program([str(script), "late_sigterm", "2"], REPO)
    programs.append(program)
    pids = [int(p) for p in program.wait_for("PIDS ")[0].split()[1:]]
    err = program.stderr()
    assert program.proc.wait(timeout=30) == 0
    assert wait_gone(pids) == []
    assert not any(word in err for word in NOISE), err
    assert not [line for line in program.lines if "survived" in line]  # it ended at once
    assert "PARENT DONE" in program.lines


def test_ctrl_c_while_workers_start_up_is_handled_by_the_parent_alone(
    tmp_path: Path, programs: list[Program]
) -> None:
    script = tmp_path / "pool_program.py"
    script.write_text(textwrap.dedent(POOL_PROGRAM))
    os.environ["SLOW_WORKER_START"] = "1.5"
    try:
        program = Program([str(script), "starting", "2"], REPO)
    finally:
        del os.environ["SLOW_WORKER_START"]
    programs.append(program)
    pids = [int(p) for p in program.wait_for("STARTED ")[0].split()[1:]]
    time.sleep(0.3)  # the workers are inside their start-up (imports), the parent sleeps
    os.killpg(program.proc.pid, signal.SIGINT)  # Ctrl-C: the whole foreground group
    err = program.stderr()
    assert program.proc.wait(timeout=30) == 0
    assert wait_gone(pids) == []
    assert program.lines[-2:] == ["PARENT INTERRUPTED", "PARENT DONE"]
    assert not any(word in err for word in NOISE), err


@pytest.mark.parametrize("watch", ["kernel", "polling"])
def test_a_worker_whose_parent_is_killed_exits_quietly(
    watch: str, tmp_path: Path, programs: list[Program], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``kernel``: the parent-death signal (Linux); ``polling``: the fallback elsewhere, a
    thread watching ``os.getppid()``."""
    script = tmp_path / "pool_program.py"
    script.write_text(textwrap.dedent(POOL_PROGRAM))
    if watch == "polling":
        monkeypatch.setenv("NO_PDEATHSIG", "1")
    program = Program([str(script), "orphan", "2"], REPO)
    programs.append(program)
    pids = [int(line.split()[-1]) for line in program.wait_for("job ", count=2)]
    os.kill(program.proc.pid, signal.SIGKILL)
    assert program.proc.wait(timeout=10) == -signal.SIGKILL
    start = time.monotonic()
    assert wait_gone(pids, timeout=20) == []  # each stopped its 60 s job
    assert time.monotonic() - start < 10
    err = program.stderr()
    assert not any(word in err for word in NOISE), err


def worker_pids(parent: int) -> list[int]:
    """The worker processes (spawned: ``multiprocessing.spawn``) among ``parent``'s children."""
    pids: list[int] = []
    for task in os.listdir(f"/proc/{parent}/task"):
        with open(f"/proc/{parent}/task/{task}/children") as f:
            pids += [int(p) for p in f.read().split()]
    found = []
    for pid in pids:
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmdline = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if "spawn_main" in cmdline:
            found.append(pid)
    return found


def test_record_killed_with_sigkill_leaves_quiet_workers_and_whole_episodes(
    tmp_path: Path, programs: list[Program]
) -> None:
    """The run's main process is killed (``kill -9``) while both workers record (with a
    camera, so that a worker has a renderer to close at exit); the orphans must exit
    without a word, and what was published must load."""
    data = tmp_path / "data"
    program = Program(
        [
            "-m",
            "trossen_arm_mujoco.scripts.record_sim_episodes",
            "--data_dir",
            str(data),
            "--num_episodes",
            "8",
            "--num_workers",
            "2",
            "--episode_len",
            "150",
            "--cam_names",
            "cam_high",
            "--image_size",
            "48x64",
        ],
        REPO,
    )
    programs.append(program)
    program.wait_for("episode 0: ", timeout=180)  # an episode is published, others run
    workers = worker_pids(program.proc.pid)
    assert len(workers) == 2, workers
    os.kill(program.proc.pid, signal.SIGKILL)
    assert program.proc.wait(timeout=10) == -signal.SIGKILL
    assert wait_gone(workers) == []  # the orphans followed their parent
    err = program.stderr()
    assert not any(word in err for word in NOISE), err
    episodes = list_episodes(data)
    assert episodes and episodes[0][0] == 0
    for _, path in episodes:
        episode = load_episode(path)  # validated: a whole episode
        assert episode.action.shape == (150, 16)
    staging = data / ".staging"
    left = [p.name for p in staging.iterdir()] if staging.exists() else []
    assert not [name for name in left if name.endswith(".tmp")], left  # partials discarded
