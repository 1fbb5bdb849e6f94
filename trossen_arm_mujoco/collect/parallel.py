"""Recording a dataset: resume planning, N local worker processes, ordered publishing.

Episode ``k`` of a run is attempt ``k`` (seed derived from the run seed and ``k``), so the
files are the same whatever the number of workers. With ``skip_failed``, attempts continue
until enough successes exist; successes get consecutive indices in attempt order.

Files are written atomically. With more than one worker (or ``skip_failed``) each attempt is
written under ``.staging/`` and renamed to its episode name in attempt order, so the folder
only ever holds episodes ``0..k`` without gaps. On SIGINT/SIGTERM the partial episodes are
discarded, finished episodes stay, and rerunning the same command continues where the run
stopped. A write the file system refuses (disk full, read-only folder, folder removed) stops
the run the same way, with :attr:`RunReport.io_error` saying why. :mod:`.ray_engine` runs the
same attempts as Ray tasks.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import shutil
import signal
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from trossen_arm_mujoco.collect.pipeline import EpisodeOutcome, EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.collect.progress import Progress
from trossen_arm_mujoco.data.io_errors import EpisodeIOError, folder_io_error, io_error
from trossen_arm_mujoco.data.reader import episode_path, list_episodes, load_episode
from trossen_arm_mujoco.data.writer import remove_stale_temp_files
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import publish

STAGING = ".staging"


@dataclass
class RunPlan:
    """Which episode indices and attempts a run records."""

    first_index: int
    first_attempt: int
    existing: list[int] = field(default_factory=list)


@dataclass
class RunReport:
    """What a run did.

    Attributes:
        saved: episodes written, in index order.
        failed: failed attempts (saved as failures, or discarded with ``skip_failed``).
        attempts: attempts finished.
        interrupted: stopped by Ctrl-C / SIGTERM.
        io_error: the file system refused a write; the run stopped (one-line message).
    """

    saved: list[EpisodeOutcome] = field(default_factory=list)
    failed: list[EpisodeOutcome] = field(default_factory=list)
    attempts: int = 0
    interrupted: bool = False
    io_error: EpisodeIOError | None = None

    @property
    def successes(self) -> int:
        return sum(o.success for o in self.saved)

    @property
    def saved_bytes(self) -> int:
        """Total size of the episodes saved by this run (bytes)."""
        return sum(o.nbytes for o in self.saved)


def failure_summary(
    failed: list[EpisodeOutcome], total: int, noun: str, episode_len: int, minimum_len: int
) -> str:
    """``"2 of 3 episodes failed: reward below max 4 (episode_len 300 < 440 the scripted
    policy needs)"``; empty when nothing failed. ``noun``: "episodes" or "attempts"."""
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


def plan_run(folder: Path, num_episodes: int, overwrite: bool) -> RunPlan:
    """Start after the highest existing index (or at 0 with ``overwrite``)."""
    existing = [k for k, _ in list_episodes(folder, missing_ok=True)]
    if overwrite or not existing:
        return RunPlan(0, 0, existing)
    last = max(existing)
    attrs = load_episode(episode_path(folder, last)).attrs
    attempt = int(attrs.get("attempt", last)) + 1
    return RunPlan(last + 1, attempt, existing)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


_WORKER: EpisodeRecorder | None = None


def _worker_init(settings: RecordSettings) -> None:
    global _WORKER
    _ignore_sigint()
    os.environ.setdefault("MUJOCO_GL", "egl")
    _WORKER = EpisodeRecorder(settings)


def _worker_record(job: tuple[int, str, bool]) -> EpisodeOutcome:
    attempt, path, overwrite = job
    assert _WORKER is not None
    return _WORKER.record(attempt, Path(path), overwrite=overwrite, create_folder=False)


def record_in_worker(settings: RecordSettings, job: tuple[int, str, bool]) -> EpisodeOutcome:
    """Record one ``(attempt, path, overwrite)`` job in a worker process that was not set up
    by the pool (a Ray task): the process's recorder is built on first use and kept for the
    next job with the same settings."""
    if _WORKER is None or _WORKER.settings != settings:
        if _WORKER is not None:
            _WORKER.close()
        _worker_init(settings)
    return _worker_record(job)


class DatasetRecorder:
    """Records episodes ``first_index .. num_episodes - 1`` into ``folder``.

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
    ):
        self.settings = settings
        self.folder = Path(folder)
        self.num_workers = num_workers
        self.skip_failed = skip_failed
        self.overwrite = overwrite
        self.step_hook = step_hook
        self.log = log
        self.progress_stream = progress_stream

    def max_attempts(self, needed: int) -> int:
        """Bound on attempts with ``skip_failed``: 3x the episodes needed, plus 10."""
        return 3 * needed + 10

    def run(self, num_episodes: int, plan: RunPlan) -> RunReport:
        self.folder.mkdir(parents=True, exist_ok=True)
        remove_stale_temp_files(self.folder)
        shutil.rmtree(self.folder / STAGING, ignore_errors=True)
        report = RunReport()
        needed = num_episodes - plan.first_index
        if needed <= 0:
            return report
        attempts = self._attempts(plan.first_attempt, needed)
        try:
            self._execute(attempts, plan.first_index, num_episodes, report)
        except KeyboardInterrupt:
            report.interrupted = True
        except EpisodeIOError as exc:
            report.io_error = exc
        except OSError as exc:  # the folder itself: staging, a finished file vanishing
            report.io_error = folder_io_error(self.folder, exc)
        finally:
            remove_stale_temp_files(self.folder)
            shutil.rmtree(self.folder / STAGING, ignore_errors=True)
        return report

    def _execute(self, attempts: range, index: int, total: int, report: RunReport) -> None:
        """Record ``attempts`` until episode ``total - 1`` is saved (the engine's part)."""
        if self.num_workers == 1:
            self._run_here(attempts, index, total, report)
        else:
            self._run_pool(attempts, index, total, report)

    @property
    def stages_files(self) -> bool:
        """Whether attempts are written under ``.staging/`` and renamed in attempt order
        (several at once could otherwise finish out of order and leave a gap on Ctrl-C)."""
        return self.skip_failed or self.num_workers > 1

    def _attempts(self, first: int, needed: int) -> range:
        count = self.max_attempts(needed) if self.skip_failed else needed
        return range(first, first + count)

    def _target(self, attempt: int, index: int) -> tuple[Path, bool]:
        """Where an attempt is written: its final name, or a staging name."""
        if self.stages_files:
            staging = self.folder / STAGING
            staging.mkdir(exist_ok=True)
            return staging / f"attempt_{attempt}.hdf5", True
        return episode_path(self.folder, index), self.overwrite

    def _publish(self, outcome: EpisodeOutcome, index: int, report: RunReport) -> bool:
        """Account for one finished attempt; returns True when it became episode ``index``."""
        report.attempts += 1
        if self.stages_files:
            assert outcome.path is not None
            if self.skip_failed and not outcome.success:
                report.failed.append(outcome)
                outcome.path.unlink(missing_ok=True)
                self.log(
                    f"attempt {outcome.attempt}: failed (reward {outcome.final_reward:g}),"
                    " discarded"
                )
                return False
            final = episode_path(self.folder, index)
            try:
                outcome.path = publish(outcome.path, final, overwrite=self.overwrite)
            except FileExistsError:
                raise UserError(
                    f"{final} appeared during the run; refusing to overwrite it"
                ) from None
            except OSError as exc:
                with contextlib.suppress(OSError):
                    outcome.path.unlink(missing_ok=True)
                raise io_error(final, exc) from exc
        report.saved.append(outcome)
        if not outcome.success:
            report.failed.append(outcome)
        status = "success" if outcome.success else "failure"
        self.log(
            f"episode {index}: {status} (final reward {outcome.final_reward:g}, "
            f"seed {outcome.seed}) -> {outcome.path} ({format_size(outcome.nbytes)})"
        )
        return True

    def _run_here(self, attempts: range, index: int, total: int, report: RunReport) -> None:
        recorder = EpisodeRecorder(self.settings, step_hook=self.step_hook)
        try:
            for attempt in attempts:
                if index >= total:
                    break
                path, overwrite = self._target(attempt, index)
                with Progress(
                    self.settings.episode_len, f"episode {index}", "step", self.progress_stream
                ) as bar:
                    outcome = recorder.record(
                        attempt, path, overwrite, bar.update, create_folder=False
                    )
                if self._publish(outcome, index, report):
                    index += 1
        finally:
            recorder.close()

    def _jobs(self, attempts: range, first_index: int) -> Iterator[tuple[int, str, bool]]:
        for i, attempt in enumerate(attempts):
            path, overwrite = self._target(attempt, first_index + i)
            yield attempt, str(path), overwrite

    def _run_pool(self, attempts: range, index: int, total: int, report: RunReport) -> None:
        ctx = mp.get_context("spawn")
        pool = ctx.Pool(self.num_workers, initializer=_worker_init, initargs=(self.settings,))
        bar = Progress(total - index, "episodes", "episode", self.progress_stream, leave=True)
        try:
            for outcome in pool.imap(_worker_record, self._jobs(attempts, index)):
                if self._publish(outcome, index, report):
                    index += 1
                    bar.update()
                if index >= total:
                    pool.terminate()
                    break
            pool.close()
        except BaseException:
            pool.terminate()
            raise
        finally:
            pool.join()
            bar.close()
