"""Recording a dataset on Ray (``trossen-mujoco record --engine ray``): one task per attempt.

This process plans the run, submits attempts as Ray tasks and publishes the finished files
in attempt order, exactly as :class:`~.parallel.DatasetRecorder` does for local workers
(lock, resume, ``skip_failed``, staging, atomic renames, Ctrl-C). Each task calls
:func:`~.parallel.record_in_worker`, so the files are those of ``--engine local`` for the
same run seed. A dead worker loses only its attempt, which Ray runs again (``max_retries``).
On a cluster every node must see the dataset folder at the same absolute path and have the
same versions of this package and MuJoCo.

Docs: docs/cli/record.md (Recording on a Ray cluster).
"""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from tqdm import tqdm

from trossen_arm_mujoco.collect.parallel import (
    DatasetRecorder,
    Job,
    RunReport,
    record_in_worker,
)
from trossen_arm_mujoco.collect.pipeline import EpisodeOutcome, RecordSettings
from trossen_arm_mujoco.errors import UserError

__all__ = [
    "CANCEL_WAIT_S",
    "FINISH_GRACE_S",
    "MAX_BUFFERED",
    "MAX_RETRIES",
    "WAIT_STEP_S",
    "BeforeAttempt",
    "RayDatasetRecorder",
]

#: Times Ray runs an attempt again after its worker process died.
MAX_RETRIES = 3

#: Finished attempts kept waiting for an earlier one, per worker, before no more are submitted.
MAX_BUFFERED = 4

#: Seconds of one wait for a task to finish (Ctrl-C is seen between waits).
WAIT_STEP_S = 0.5

#: Seconds to wait for cancelled tasks to stop before their staging files are removed.
CANCEL_WAIT_S = 30.0

#: Called in the worker with the attempt number before the attempt is recorded.
BeforeAttempt = Callable[[int], None]

#: Seconds an interrupt waits for tasks that are returning (their staged file written) so
#: that their outcomes are kept.
FINISH_GRACE_S = 1.0


def _record_task(
    settings: RecordSettings, job: tuple[int, str, bool], before: BeforeAttempt | None
) -> EpisodeOutcome:
    """Body of one Ray task: record attempt ``job[0]`` into ``job[1]``."""
    if before is not None:
        before(job[0])
    return record_in_worker(settings, job)


class RayDatasetRecorder(DatasetRecorder):
    """:class:`DatasetRecorder` whose attempts run as tasks on the connected Ray instance.

    Args:
        settings, folder, skip_failed, overwrite, log: as for :class:`DatasetRecorder`.
        max_in_flight: attempts running at once (default: the cluster's CPUs); a worker
            that finishes before an earlier attempt picks up the next attempt.
        max_retries: times an attempt is run again after its worker process died.
        before_attempt: called in the worker before each attempt (tests use it to kill a
            worker); must be picklable by Ray.

    Needs ``ray.init`` to have been called (see :func:`.ray_session.ray_session`).
    """

    def __init__(
        self,
        settings: RecordSettings,
        folder: Path,
        max_in_flight: int | None = None,
        skip_failed: bool = False,
        overwrite: bool = False,
        max_retries: int = MAX_RETRIES,
        before_attempt: BeforeAttempt | None = None,
        log: Callable[[str], None] = print,
    ):
        import ray

        if not ray.is_initialized():
            raise RuntimeError("call ray.init() (or use ray_session()) before recording on Ray")
        if max_in_flight is None:
            max_in_flight = max(1, int(ray.cluster_resources().get("CPU", 1)))
        if max_in_flight < 1:
            raise UserError(f"--num_workers must be at least 1, got {max_in_flight}")
        super().__init__(
            settings,
            folder,
            num_workers=max_in_flight,
            skip_failed=skip_failed,
            overwrite=overwrite,
            log=log,
        )
        self.max_retries = max_retries
        self.before_attempt = before_attempt
        self._task = ray.remote(max_retries=max_retries, retry_exceptions=False)(_record_task)

    @property
    def stages_files(self) -> bool:
        return True

    def _execute(self, jobs: Sequence[Job], report: RunReport) -> None:
        import ray

        self._staging()
        source = iter(jobs)
        pending: deque = deque()  # (job, ref), in attempt order; finished ones included
        settings_ref = ray.put(self.settings)
        bar = tqdm(total=len(self._todo), desc="episodes", unit="episode")
        try:
            while not self.done:
                running = self._top_up(ray, pending, source, settings_ref)
                if not pending:
                    break
                job, ref = pending[0]
                if ref in running:  # wait for any task to finish, in short steps (Ctrl-C)
                    ray.wait(running, num_returns=1, timeout=WAIT_STEP_S, fetch_local=False)
                    continue
                pending.popleft()
                before = len(self._todo)
                self._deliver(job, self._result(ray, job.attempt, ref), report)
                bar.update(before - len(self._todo))
        finally:
            if not self.done:
                self._keep_finished(ray, pending)
            self._cancel(ray, [ref for _, ref in pending])
            bar.close()

    def _keep_finished(self, ray, pending: deque) -> None:
        """Hold the outcomes of tasks that finished (for publishing after an interrupt)."""
        refs = [ref for _, ref in pending]
        if not refs:
            return
        # a task publishes its staged file just before it returns: give those a moment
        ready, _ = ray.wait(refs, num_returns=len(refs), timeout=FINISH_GRACE_S, fetch_local=True)
        ready_set = set(ready)
        for job, ref in pending:
            if ref in ready_set:
                with contextlib.suppress(Exception):  # a lost or failed task: nothing kept
                    self._finished.setdefault(job.position, (job, ray.get(ref, timeout=5)))

    def _top_up(self, ray, pending: deque, jobs: Iterator[Job], settings_ref) -> list:
        """Submit attempts until ``num_workers`` run at once (at most ``MAX_BUFFERED`` times
        that many finished but unpublished); returns the refs still running."""
        refs = [ref for _, ref in pending]
        running = []
        if refs:
            _, running = ray.wait(refs, num_returns=len(refs), timeout=0, fetch_local=False)
        while len(running) < self.num_workers and len(pending) < MAX_BUFFERED * self.num_workers:
            job = next(jobs, None)
            if job is None:
                break
            ref = self._task.remote(settings_ref, job.payload, self.before_attempt)
            pending.append((job, ref))
            running.append(ref)
        return running

    def _result(self, ray, attempt: int, ref) -> EpisodeOutcome:
        """The outcome of one task; the task's own error is raised as it is."""
        try:
            return ray.get(ref)
        except ray.exceptions.RayTaskError as exc:
            if isinstance(exc.cause, UserError):  # one-line message, as with local workers
                raise exc.cause from None
            raise
        except (
            ray.exceptions.WorkerCrashedError,
            ray.exceptions.NodeDiedError,
            ray.exceptions.OutOfMemoryError,
        ) as exc:
            raise UserError(
                f"attempt {attempt}: the Ray worker running it was lost in each of "
                f"{self.max_retries + 1} tries (last: {type(exc).__name__}); see the Ray logs "
                "(out of memory?) and rerun the same command to continue"
            ) from None

    def _cancel(self, ray, refs: list) -> None:
        """Stop tasks that are no longer needed (or interrupted) and wait until they are
        gone, so that none still writes when the staging folder is removed.

        Finished tasks are not cancelled: ray 2.60's driver aborts ("Tried to complete task
        that was not pending") when a task is force-cancelled while its reply is arriving.
        """
        if not refs:
            return
        _, running = ray.wait(refs, num_returns=len(refs), timeout=0)
        for ref in running:
            ray.cancel(ref, force=True)
        ray.wait(refs, num_returns=len(refs), timeout=CANCEL_WAIT_S)
