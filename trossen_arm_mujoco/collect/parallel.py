"""Recording a dataset: N local worker processes, ordered publishing, one writer per folder.

A run holds the folder's lock (:mod:`~trossen_arm_mujoco.data.dataset_lock`) throughout and
records what :func:`.resume.plan_run` says: without ``skip_failed`` each planned index is
one attempt (seed derived from the run seed and ``k``), so the files are the same whatever
the number of workers; with ``skip_failed`` attempts continue until the planned indices hold
successes. Files are written atomically (via ``.staging/``, published in attempt order). The
workers are a :class:`~trossen_arm_mujoco.worker_pool.WorkerPool`'s: a dead one loses only its
attempt. On SIGINT/SIGTERM, or a refused write (:attr:`RunReport.io_error`), partial episodes
are discarded and finished ones published; rerunning the command continues.
:mod:`.ray_engine` runs the same attempts on Ray.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import sys
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from trossen_arm_mujoco.collect.joint_policy import JointPolicyRecorder, make_recorder
from trossen_arm_mujoco.collect.pipeline import EpisodeOutcome, EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.collect.progress import Progress
from trossen_arm_mujoco.collect.resume import RunPlan, plan_run
from trossen_arm_mujoco.data.dataset_lock import DatasetLock
from trossen_arm_mujoco.data.io_errors import EpisodeIOError, folder_io_error, io_error
from trossen_arm_mujoco.data.reader import EpisodeError, episode_path, load_episode
from trossen_arm_mujoco.data.temp_files import remove_stale_temp_files
from trossen_arm_mujoco.errors import Terminated, UserError
from trossen_arm_mujoco.fileio import publish
from trossen_arm_mujoco.stopping import NOTE, StopSignals
from trossen_arm_mujoco.worker_pool import WorkerPool

__all__ = [
    "STAGING",
    "DatasetRecorder",
    "Job",
    "RunReport",
    "failure_summary",
    "format_size",
    "record_in_worker",
]

STAGING = ".staging"

#: Finished attempts kept waiting for an earlier one, per worker, before no more start.
MAX_BUFFERED = 4


@dataclass(frozen=True)
class Job:
    """One attempt of a run.

    Attributes:
        position: place in the run's attempt order (results are published in this order).
        attempt: attempt number (its seed derives from the run seed and this number).
        index: the episode it becomes; None with ``skip_failed`` (the next free index, if
            it succeeds).
        path: where it is written (its final name, or a staging name).
        overwrite: whether that write may replace an existing file.
    """

    position: int
    attempt: int
    index: int | None
    path: Path
    overwrite: bool

    @property
    def payload(self) -> tuple[int, str, bool]:
        """What a worker gets: ``(attempt, path, overwrite)``."""
        return self.attempt, str(self.path), self.overwrite


@dataclass
class RunReport:
    """What a run did.

    Attributes:
        saved: episodes written, in the order they were published.
        failed: failed attempts (saved as failures, or discarded with ``skip_failed``).
        attempts: attempts finished.
        interrupted: stopped by Ctrl-C / SIGTERM.
        terminated: the interrupt was SIGTERM.
        io_error: the file system refused a write; the run stopped (one-line message).
        plan: what the run was asked to record.
        saved_at: the episode index of each of ``saved``.
    """

    saved: list[EpisodeOutcome] = field(default_factory=list)
    failed: list[EpisodeOutcome] = field(default_factory=list)
    attempts: int = 0
    interrupted: bool = False
    terminated: bool = False
    io_error: EpisodeIOError | None = None
    plan: RunPlan | None = None
    saved_at: list[int] = field(default_factory=list)

    @property
    def successes(self) -> int:
        """Number of saved episodes that succeeded."""
        return sum(o.success for o in self.saved)

    @property
    def saved_bytes(self) -> int:
        """Total size of the episodes saved by this run (bytes)."""
        return sum(o.nbytes for o in self.saved)

    @property
    def failed_indices(self) -> list[int]:
        """Indices of the episodes this run saved as failures."""
        return sorted(k for o, k in zip(self.saved, self.saved_at, strict=True) if not o.success)


def failure_summary(
    failed: list[EpisodeOutcome], total: int, noun: str, episode_len: int, minimum_len: int
) -> str:
    """``"2 of 3 episodes failed: reward below max 4 (episode_len 300 < 440 the scripted
    policy needs)"``; empty when nothing failed.

    Args:
        failed: the failed episodes' outcomes.
        total: the number of episodes or attempts run.
        noun: ``"episodes"`` or ``"attempts"``.
        episode_len: the run's episode length (steps).
        minimum_len: the steps the scripted policy needs (named when ``episode_len`` is
            shorter and episodes failed on their reward).
    """
    if not failed:
        return ""
    reasons = Counter(o.failure() or "not successful" for o in failed)
    if len(reasons) == 1:
        why = next(iter(reasons))
    else:
        why = ", ".join(f"{n} {reason}" for reason, n in reasons.most_common())
    text = f"{len(failed)} of {total} {noun} failed: {why}"
    if episode_len < minimum_len and any(r.startswith("reward") for r in reasons):
        text += f" (episode_len {episode_len} < {minimum_len} the scripted policy needs)"
    return text


def format_size(nbytes: float) -> str:
    """``"97.1 MB"``: bytes in kB / MB / GB (powers of 1000)."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.{3 if scale == 1e9 else 1}f} {unit}"
    return f"{int(nbytes)} B"


_WORKER: EpisodeRecorder | JointPolicyRecorder | None = None


class _PoolRecorder:
    """A pool worker's runner: one recorder, each job an ``(attempt, path, overwrite)``."""

    def __init__(self, settings: RecordSettings) -> None:
        self.recorder = make_recorder(settings)

    def run(self, job: tuple[int, str, bool]) -> EpisodeOutcome:
        attempt, path, overwrite = job
        return self.recorder.record(attempt, Path(path), overwrite=overwrite, create_folder=False)

    def close(self) -> None:
        self.recorder.close()


def record_in_worker(settings: RecordSettings, job: tuple[int, str, bool]) -> EpisodeOutcome:
    """Record one ``(attempt, path, overwrite)`` job in a worker process that was not set up
    by the pool (a Ray task): the process's recorder is built on first use and kept for the
    next job with the same settings."""
    global _WORKER
    if _WORKER is None or _WORKER.settings != settings:
        if _WORKER is not None:
            _WORKER.close()
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        os.environ.setdefault("MUJOCO_GL", "egl")
        _WORKER = make_recorder(settings)
    attempt, path, overwrite = job
    return _WORKER.record(attempt, Path(path), overwrite=overwrite, create_folder=False)


def _describe(payload: tuple[int, str, bool]) -> str:
    return f"attempt {payload[0]}"


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


@contextlib.contextmanager
def _signals_held(report: RunReport) -> Iterator[None]:
    """Hold Ctrl-C / SIGTERM while finished files are put in place: a signal meanwhile
    marks the run interrupted instead of cutting the renames short."""
    holder = StopSignals(NOTE, (signal.SIGINT, signal.SIGTERM))
    try:
        with holder.handling():
            yield
    finally:
        if holder.late:
            report.interrupted = True
            report.terminated = report.terminated or signal.SIGTERM in holder.late


class DatasetRecorder:
    """Records the episodes a :class:`RunPlan` asks for into ``folder``.

    Args:
        settings: shared run settings.
        folder: dataset folder (created).
        num_workers: processes; 1 records in this process with a per-step progress bar.
        skip_failed: keep attempting until the episodes are successes (bounded).
        overwrite: replace existing episodes instead of continuing after them.
        step_hook: per-step callback in this process (live view); needs 1 worker.
        log: where the per-episode lines go (default print).
        progress_stream: where progress goes (default stderr): a bar on a terminal, a
            plain line every ``progress.LOG_INTERVAL_S`` seconds otherwise.
        wait: wait for another run that holds the folder instead of refusing.
        warn: where warnings go (a worker that died; default stderr).
    """

    def __init__(
        self,
        settings: RecordSettings,
        folder: Path,
        num_workers: int = 1,
        skip_failed: bool = False,
        overwrite: bool = False,
        step_hook: Callable | None = None,
        log: Callable[[str], None] = print,
        progress_stream=None,
        wait: bool = False,
        warn: Callable[[str], None] = _stderr,
    ):
        self.settings = settings
        self.folder = Path(folder)
        self.num_workers = num_workers
        self.skip_failed = skip_failed
        self.overwrite = overwrite
        self.step_hook = step_hook
        self.log = log
        self.progress_stream = progress_stream
        self.wait = wait
        self.warn = warn

    def max_attempts(self, needed: int) -> int:
        """Bound on attempts with ``skip_failed``: 3x the episodes needed, plus 10."""
        return 3 * needed + 10

    def run(self, num_episodes: int, plan: RunPlan | None = None) -> RunReport:
        """Record until episodes ``0 .. num_episodes - 1`` exist as ``plan`` says (default:
        :func:`plan_run` of the folder, made under the lock)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        with DatasetLock(self.folder, wait=self.wait):
            if plan is None:
                plan = plan_run(self.folder, num_episodes, self.overwrite, self.settings)
            return self._run_locked(plan)

    def _run_locked(self, plan: RunPlan) -> RunReport:
        self._clean()
        report = RunReport(plan=plan)
        self._plan = plan
        self._todo = list(plan.indices)
        self._finished: dict[int, tuple[Job, EpisodeOutcome]] = {}
        self._next = 0
        if not self._todo:
            return report
        jobs = self._jobs(plan)
        try:
            self._execute(jobs, report)
        except KeyboardInterrupt as exc:
            report.interrupted = True
            report.terminated = isinstance(exc, Terminated)
        except EpisodeIOError as exc:
            report.io_error = exc
        except OSError as exc:  # the folder itself: staging, a finished file vanishing
            report.io_error = folder_io_error(self.folder, exc)
        finally:
            with _signals_held(report):
                if self._todo:
                    self._publish_finished(report)
                self._clean()
        return report

    def _clean(self) -> None:
        remove_stale_temp_files(self.folder)
        shutil.rmtree(self.folder / STAGING, ignore_errors=True)

    def _execute(self, jobs: Sequence[Job], report: RunReport) -> None:
        """Record ``jobs`` until the planned indices are filled (the engine's part); each
        finished attempt goes to :meth:`_deliver`."""
        if self.num_workers == 1:
            self._run_here(jobs, report)
        else:
            self._run_pool(jobs, report)

    @property
    def stages_files(self) -> bool:
        """Whether attempts are written under ``.staging/`` and renamed in attempt order
        (several at once could otherwise finish out of order)."""
        return self.skip_failed or self.num_workers > 1

    def _jobs(self, plan: RunPlan) -> list[Job]:
        if self.skip_failed:
            first = plan.first_attempt
            attempts = range(first, first + self.max_attempts(len(plan.indices)))
            return [Job(i, a, None, *self._target(a, None, plan)) for i, a in enumerate(attempts)]
        return [
            Job(i, a, k, *self._target(a, k, plan))
            for i, (a, k) in enumerate(zip(plan.attempts, plan.indices, strict=True))
        ]

    def _target(self, attempt: int, index: int | None, plan: RunPlan) -> tuple[Path, bool]:
        """Where an attempt is written: its final name, or a staging name."""
        if self.stages_files:
            return self.folder / STAGING / f"attempt_{attempt}.hdf5", True
        assert index is not None
        return episode_path(self.folder, index), plan.replaces(index)

    def _staging(self) -> None:
        if self.stages_files:
            (self.folder / STAGING).mkdir(exist_ok=True)

    @property
    def done(self) -> bool:
        """Whether every planned index holds its episode."""
        return not self._todo

    def _deliver(self, job: Job, outcome: EpisodeOutcome, report: RunReport) -> None:
        """Take a finished attempt; publish it and any held-back later ones in order."""
        self._finished[job.position] = (job, outcome)
        while self._next in self._finished and not self.done:
            self._publish(*self._finished.pop(self._next), report)
            self._next += 1

    def _publish_finished(self, report: RunReport) -> None:
        """After an interrupt or error: publish every finished attempt still held back, in
        attempt order (a rename each; stops at the first that fails)."""
        for position in sorted(self._finished):
            if self.done:
                return
            job, outcome = self._finished.pop(position)
            try:
                self._publish(job, outcome, report)
            except (OSError, UserError) as exc:
                self.warn(f"warning: attempt {job.attempt} was not kept: {exc}")
                return

    def _publish(self, job: Job, outcome: EpisodeOutcome, report: RunReport) -> bool:
        """Account for one finished attempt; returns True when it became an episode."""
        report.attempts += 1
        if self.skip_failed and not outcome.success:
            report.failed.append(outcome)
            if outcome.path is not None:
                outcome.path.unlink(missing_ok=True)
            self.log(
                f"attempt {outcome.attempt}: failed (reward {outcome.final_reward:g}), discarded"
            )
            return False
        index = self._todo[0] if job.index is None else job.index
        if self.stages_files:
            assert outcome.path is not None
            outcome.path = self._move_into_place(outcome.path, index)
        self._todo.remove(index)
        report.saved.append(outcome)
        report.saved_at.append(index)
        if not outcome.success:
            report.failed.append(outcome)
        status = "success" if outcome.success else "failure"
        self.log(
            f"episode {index}: {status} (final reward {outcome.final_reward:g}, "
            f"seed {outcome.seed}) -> {outcome.path} ({format_size(outcome.nbytes)})"
        )
        return True

    def _move_into_place(self, staged: Path, index: int) -> Path:
        """Rename a staged attempt to episode ``index``, after reading it back."""
        final = episode_path(self.folder, index)
        try:
            load_episode(staged)
        except EpisodeError as exc:
            staged.unlink(missing_ok=True)
            raise UserError(
                f"{staged.name} does not read back ({exc}); not published as {final.name}; "
                "rerun the same command to record it again"
            ) from None
        try:
            return publish(staged, final, overwrite=self._plan.replaces(index))
        except FileExistsError:
            raise UserError(f"{final} appeared during the run; refusing to overwrite it") from None
        except OSError as exc:
            with contextlib.suppress(OSError):
                staged.unlink(missing_ok=True)
            raise io_error(final, exc) from exc

    def _run_here(self, jobs: Sequence[Job], report: RunReport) -> None:
        self._staging()
        recorder = make_recorder(self.settings, step_hook=self.step_hook)
        try:
            for job in jobs:
                if self.done:
                    break
                index = self._todo[0] if job.index is None else job.index
                with Progress(
                    self.settings.episode_len, f"episode {index}", "step", self.progress_stream
                ) as bar:
                    outcome = recorder.record(
                        job.attempt, job.path, job.overwrite, bar.update, create_folder=False
                    )
                self._deliver(job, outcome, report)
        finally:
            recorder.close()

    def _run_pool(self, jobs: Sequence[Job], report: RunReport) -> None:
        self._staging()
        pool = WorkerPool(
            min(self.num_workers, len(jobs)),
            partial(_PoolRecorder, self.settings),
            window=MAX_BUFFERED * self.num_workers,
            describe=_describe,
            warn=self.warn,
        )
        bar = Progress(len(self._todo), "episodes", "episode", self.progress_stream, leave=True)
        try:
            for position, outcome in pool.results(job.payload for job in jobs):
                before = len(self._todo)
                self._deliver(jobs[position], outcome, report)
                bar.update(before - len(self._todo))
                if self.done:
                    break
        finally:
            for position, outcome in pool.shutdown(cancel=True):
                self._finished.setdefault(position, (jobs[position], outcome))
            bar.close()
