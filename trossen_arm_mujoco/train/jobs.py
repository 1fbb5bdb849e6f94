"""The child processes of ``trossen-mujoco train`` (recording, export, the encoder,
training, evaluation): each one's own wall and CPU time, its log, its one-line failure, and
its end with the command's.

Each child starts in a process group of its own (its workers with it) and asks the kernel
for SIGTERM when this process dies; a Ctrl-C or SIGTERM of the command (a
``KeyboardInterrupt`` under ``errors.run_cli``) sends SIGTERM to every running child's
group, then SIGKILL to what is left after :data:`GRACE_S`.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from trossen_arm_mujoco.errors import UserError, describe_os_error
from trossen_arm_mujoco.processes import available_cpus, parent_death_signal

__all__ = ["GRACE_S", "Job", "JobSpec", "child_env", "cli_command", "cores", "run_jobs"]

#: Seconds a stopped child's group has to end after SIGTERM before SIGKILL.
GRACE_S = 10.0


def child_env() -> dict[str, str]:
    """The environment every child gets: headless rendering, no network, no wandb."""
    return {**os.environ, "MUJOCO_GL": "egl", "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled"}


def cli_command(python: str) -> list[str]:
    """``trossen-mujoco`` run by ``python``."""
    return [python, "-m", "trossen_arm_mujoco.cli"]


@dataclass(frozen=True)
class JobSpec:
    """One child to run: its name in messages, its command line and its log."""

    name: str
    args: Sequence[str]
    log: Path
    ok: tuple[int, ...] = (0,)


class Job:
    """A running child whose own wall and CPU time (``os.wait4``'s rusage) are kept."""

    def __init__(self, spec: JobSpec, env: dict[str, str]) -> None:
        self.spec, self.start = spec, time.perf_counter()
        self._out = open(spec.log, "w")  # noqa: SIM115 (closed by wait or stop)
        request = parent_death_signal(signal.SIGTERM)
        try:
            self.proc = subprocess.Popen(
                list(spec.args),
                stdout=self._out,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,  # its own group: stopped with its workers
                preexec_fn=request,
            )
        except OSError as exc:  # LeRobot's Python is not a program this user can run
            self._out.close()
            raise UserError(
                f"cannot start {spec.name}: {spec.args[0]}: {describe_os_error(exc)}"
            ) from None

    def wait(self) -> dict[str, float]:
        """Wait for the child; its ``{"wall_s", "cpu_s"}``; a UserError if it failed."""
        _, status, usage = os.wait4(self.proc.pid, 0)
        self.proc.returncode = os.waitstatus_to_exitcode(status)
        self._out.close()
        took = {
            "wall_s": round(time.perf_counter() - self.start, 1),
            "cpu_s": round(usage.ru_utime + usage.ru_stime, 1),
        }
        name, log = self.spec.name, self.spec.log
        print(
            f"{name}: {took['wall_s']:.0f} s wall, {took['cpu_s']:.0f} s CPU (log {log})",
            flush=True,
        )
        if self.proc.returncode not in self.spec.ok:
            raise UserError(f"{name} failed (exit {self.proc.returncode}); see {log}")
        return took

    def stop(self) -> None:
        """End the child and its group: SIGTERM, then SIGKILL after :data:`GRACE_S`."""
        self._signal(signal.SIGTERM)
        try:
            self.proc.wait(timeout=GRACE_S)
        except subprocess.TimeoutExpired:
            self._signal(signal.SIGKILL)
            self.proc.wait()
        self._signal(signal.SIGKILL)  # workers of a child that ended before them
        self._out.close()

    def _signal(self, signum: int) -> None:
        try:
            os.killpg(self.proc.pid, signum)
        except (ProcessLookupError, PermissionError):
            pass


def run_jobs(jobs: Sequence[JobSpec], env: dict[str, str], at_once: int = 1) -> list[dict]:
    """Run the jobs, ``at_once`` at a time; their timings in order. A Ctrl-C or SIGTERM (or a
    job's failure) stops every running job's process group before it passes on.

    Args:
        jobs: the jobs (name, command line, log).
        env: the children's environment variables (threads, paths).
        at_once: how many run at a time.
    """
    results: dict[int, dict] = {}
    pending, running = list(enumerate(jobs)), []
    try:
        while pending or running:
            while pending and len(running) < max(1, at_once):
                i, spec = pending.pop(0)
                running.append((i, Job(spec, env)))
            i, job = running[0]
            results[i] = job.wait()
            running.pop(0)
    except BaseException:
        for _, job in running:
            if job.proc.returncode is None:
                job.stop()
        raise
    return [results[i] for i in range(len(jobs))]


def cores() -> int:
    """CPUs this process may use."""
    return available_cpus()
