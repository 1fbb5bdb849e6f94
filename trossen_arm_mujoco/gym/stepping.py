"""Stepping regimes: how one policy step maps onto wall-clock time.

- ``fast`` (default): ``policy_dt`` of physics as fast as possible; deterministic.
- ``paused``: as ``fast``, then sleeps so that the step lasts ``policy_dt`` of wall time.
- ``realtime``: a background thread advances physics in wall-clock time, one control tick
  (``ctrl_dt``) at a time, also while the policy thinks; ``step`` hands the action over and
  returns at once with the latest state. A backlog over ``MAX_LAG`` s is dropped
  (``dropped_s``).

Every regime advances time through ``sim.scene.Scene.step``; all access to the simulation
state goes through ``stepper.lock`` (thread-safety). Docs: docs/gym/index.md.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Mapping

import numpy as np

from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.tasks.task import Task

__all__ = [
    "MAX_LAG",
    "STEPPING_MODES",
    "PausedStepper",
    "RealtimeStepper",
    "Stepper",
    "make_stepper",
]

STEPPING_MODES = ("fast", "paused", "realtime")
MAX_LAG = 0.25


class Stepper:
    """Fast stepping: ``policy_dt / ctrl_dt`` control ticks, no waiting."""

    mode = "fast"

    def __init__(self) -> None:
        self._null = contextlib.nullcontext()

    @property
    def lock(self) -> contextlib.AbstractContextManager:
        """Held while reading or writing the simulation state."""
        return self._null

    def start(self, task: Task) -> None:
        """Begin an episode (after the task is reset)."""

    def stop(self) -> None:
        """Stop advancing the simulation (before a reset or close)."""

    def step(self, task: Task, commands: Mapping[str, np.ndarray]) -> None:
        """Advance ``task`` by one policy step under ``commands`` (group id -> command),
        as fast as the CPU allows."""
        task.advance(commands)

    def close(self) -> None:
        """Stop stepping (a background thread, if any) for good."""
        self.stop()


class PausedStepper(Stepper):
    """Each step lasts ``policy_dt`` of wall time (sleeps the remainder)."""

    mode = "paused"

    def __init__(self, clock=time.perf_counter, sleep=time.sleep) -> None:
        super().__init__()
        self._clock, self._sleep = clock, sleep

    def step(self, task, commands):
        """One policy step, then wait out the rest of ``policy_dt`` (s) of wall-clock time."""
        start = self._clock()
        super().step(task, commands)
        remaining = task.policy_dt - (self._clock() - start)
        if remaining > 0:
            self._sleep(remaining)


class RealtimeStepper(Stepper):
    """Physics runs in a daemon thread at wall-clock speed while the policy thinks."""

    mode = "realtime"

    def __init__(self) -> None:
        super().__init__()
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._task: Task | None = None
        self.dropped_s = 0.0
        self.error: BaseException | None = None

    @property
    def lock(self) -> contextlib.AbstractContextManager:
        return self._lock

    def start(self, task: Task) -> None:
        self.stop()
        self._task, self.error = task, None
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="trossen-realtime", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None

    def step(self, task, commands):
        """Hand ``commands`` to the physics thread (started at the first call), which
        keeps stepping in real time between calls; a failure of that thread is raised here."""
        if self.error is not None:
            raise RuntimeError("the realtime physics thread failed") from self.error
        if self._thread is None:
            self.start(task)
        with self._lock:
            task.apply_action(commands)  # validates now, in the caller's thread
            task.finish_step()

    def _run(self) -> None:
        task = self._task
        scene = task.scene
        wall0 = time.perf_counter()
        sim0 = scene.data.time
        try:
            while not self._stop.is_set():
                with self._lock:
                    scene.step(1)
                    ahead = (scene.data.time - sim0) - (time.perf_counter() - wall0)
                if ahead > 0:
                    self._stop.wait(ahead)
                elif -ahead > MAX_LAG:
                    self.dropped_s += -ahead
                    wall0 += -ahead
        except BaseException as exc:  # surfaced by the next step()
            self.error = exc


def make_stepper(mode: str) -> Stepper:
    """A stepper for a regime; a UserError listing the valid ones when unknown."""
    classes = {"fast": Stepper, "paused": PausedStepper, "realtime": RealtimeStepper}
    if mode not in classes:
        raise unknown_name_error("stepping mode", mode, STEPPING_MODES)
    return classes[mode]()
