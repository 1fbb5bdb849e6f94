"""The child processes of ``train_eval.py`` (recording, export, the encoder, training,
evaluation): each one's own wall and CPU time, and the one-line failure."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path


def cores() -> int:
    """CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def fail(message: str) -> None:
    sys.exit(f"error: {message}")


class Job:
    """A child process whose own wall and CPU time (``os.wait4``'s rusage) are kept."""

    def __init__(self, name: str, args: list[str], log: Path, env: dict, ok: tuple = (0,)):
        self.name, self.log, self.start, self.ok = name, log, time.perf_counter(), ok
        self._out = open(log, "w")
        self.proc = subprocess.Popen(args, stdout=self._out, stderr=subprocess.STDOUT, env=env)

    def wait(self) -> dict:
        """Wait for the child; its ``{"wall_s", "cpu_s"}``; exits with a line if it failed."""
        _, status, usage = os.wait4(self.proc.pid, 0)
        self.proc.returncode = os.waitstatus_to_exitcode(status)
        self._out.close()
        took = {
            "wall_s": round(time.perf_counter() - self.start, 1),
            "cpu_s": round(usage.ru_utime + usage.ru_stime, 1),
        }
        print(
            f"{self.name}: {took['wall_s']:.0f} s wall, {took['cpu_s']:.0f} s CPU (log {self.log})",
            flush=True,
        )
        if self.proc.returncode not in self.ok:
            fail(f"{self.name} failed (exit {self.proc.returncode}); see {self.log}")
        return took


def run_jobs(jobs: list[tuple[str, list[str], Path]], env: dict, at_once: int) -> list[dict]:
    """Run the jobs, ``at_once`` at a time; their timings in order."""
    results: dict[int, dict] = {}
    pending, running = list(enumerate(jobs)), []
    while pending or running:
        while pending and len(running) < max(1, at_once):
            i, (name, args, log) = pending.pop(0)
            running.append((i, Job(name, args, log, env)))
        i, job = running.pop(0)
        results[i] = job.wait()
    return [results[i] for i in range(len(jobs))]
