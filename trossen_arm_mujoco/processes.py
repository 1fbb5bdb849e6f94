"""What a process may use and how it ends with its parent: the CPUs it may run on, and the
kernel's signal when its parent dies (Linux's ``PR_SET_PDEATHSIG``).

- :func:`available_cpus`: the one CPU count of the package (record's ``--num_workers`` cap,
  eval's workers and threads, the image compression threads).
- :func:`parent_death_signal`: the one way a child asks for a signal when its parent ends
  (the workers of :mod:`~trossen_arm_mujoco.worker_pool`, record's and eval's; the ``serve``
  child of ``eval --backend wire``).

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
from collections.abc import Callable

__all__ = ["PR_SET_PDEATHSIG", "available_cpus", "parent_death_signal"]

#: ``prctl`` option: the signal a process gets when its parent ends (linux/prctl.h).
PR_SET_PDEATHSIG = 1


def available_cpus() -> int:
    """CPUs this process may run on: its CPU affinity where the OS tells, else the count (at
    least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def parent_death_signal(signum: int = signal.SIGTERM) -> Callable[[], bool] | None:
    """A function asking the kernel to send the process that calls it ``signum`` when its
    parent ends (even by SIGKILL), returning whether that was granted; None where the kernel
    cannot (not Linux, no ``prctl``).

    Everything is looked up here, so the function may run between fork and exec (a
    ``preexec_fn``). The request is for the parent *thread*: it fires when the thread that
    started the process exits."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl  # the C library of this process
    except (OSError, AttributeError, TypeError):
        return None
    number = int(signum)

    def request() -> bool:
        """Ask for ``signum`` at the parent's death; whether it was granted."""
        return prctl(PR_SET_PDEATHSIG, number, 0, 0, 0) == 0

    return request
