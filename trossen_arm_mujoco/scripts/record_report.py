"""What a record run says: the plan before it starts, warnings, and the outcome at its end.

``say_plan`` names what a run that continues a dataset keeps and records;
``warn_short_episodes`` and ``warn_disk_space`` warn before recording; ``report_run`` prints
the outcome (episodes saved, sizes, the success line and why episodes failed, or the one
``error:`` line of a refused write, or what an interrupt kept) and returns the exit status.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from trossen_arm_mujoco.collect.parallel import failure_summary, format_size
from trossen_arm_mujoco.collect.resume import format_indices
from trossen_arm_mujoco.errors import EXIT_INTERRUPTED, EXIT_TERMINATED, UserError, report_error

__all__ = [
    "EXIT_FAILED_EPISODES",
    "report_run",
    "say_plan",
    "warn_disk_space",
    "warn_short_episodes",
]

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.parallel import RunReport
    from trossen_arm_mujoco.collect.pipeline import RecordSettings
    from trossen_arm_mujoco.collect.resume import RunPlan
    from trossen_arm_mujoco.data.io_errors import EpisodeIOError

#: Exit status when some episodes failed (without --skip_failed).
EXIT_FAILED_EPISODES = 1


def say_plan(plan: RunPlan, folder: Path, num_episodes: int) -> None:
    """One line on what a run that continues a dataset keeps and records.

    Args:
        plan: the run's plan (``collect.resume.plan_run``).
        folder: the dataset folder.
        num_episodes: the episodes the run should leave.
    """
    if not (plan.existing or plan.failed):
        return
    parts = [f"keeping {format_indices(plan.existing)}"] if plan.existing else []
    gaps = [k for k in plan.gaps if k < num_episodes and k in plan.indices]
    if gaps:
        parts.append(f"missing: {format_indices(gaps)}")
    again = [k for k in plan.indices if k in plan.failed]
    if again:
        parts.append(f"failed before, recording again: {format_indices(again)}")
    print(f"continuing the dataset in {folder}: " + "; ".join(parts))


def warn_short_episodes(task_name: str, episode_len: int, minimum_len: int) -> None:
    """Warn when episodes end before the scripted policy of ``task_name`` can finish.

    Args:
        task_name: the registered task.
        episode_len: the run's episode length (steps).
        minimum_len: the steps its scripted policy needs.
    """
    if episode_len < minimum_len:
        print(
            f"warning: --episode_len {episode_len} is shorter than the {minimum_len} steps "
            f"the scripted policy of '{task_name}' needs; its episodes will end before "
            f"the task is done and count as failed (use --episode_len {minimum_len} or more)",
            file=sys.stderr,
        )


def warn_disk_space(folder: Path, settings: RecordSettings, count: int) -> None:
    """Warn when raw (uncompressed) episodes cannot fit in the free space.

    Args:
        folder: the dataset folder.
        settings: the run's settings (cameras, image size, episode length, compression).
        count: the episodes to record.
    """
    import shutil

    if settings.compression != "none":
        return  # compressed sizes are not known in advance
    per_step = len(settings.cam_names) * settings.height * settings.width * 3 + 4 * 56
    need = per_step * settings.episode_len * count
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if need > free:
        print(
            f"warning: {count} episode(s) need about {format_size(need)} but {folder} has "
            f"{format_size(free)} free; free disk space, record fewer episodes or use "
            "--compression gzip",
            file=sys.stderr,
        )


def report_run(
    args: argparse.Namespace,
    report: RunReport,
    max_attempts: int,
    plan: RunPlan,
    folder: Path,
    num_episodes: int,
    wall: float,
    episode_len: int,
    minimum_len: int,
) -> int:
    """Print a finished (or interrupted) run's outcome; the exit status.

    Args:
        args: the run's flags (``task_name``, ``skip_failed``).
        report: what the recorder returns.
        max_attempts: the recorder's bound on attempts for the planned episodes.
        plan: what the run was asked to record.
        folder: the dataset folder.
        num_episodes: episodes the dataset should hold.
        wall: the run's duration (s).
        episode_len: steps per episode.
        minimum_len: the steps the task's scripted policy needs.
    """
    saved = report.saved
    if report.io_error is not None:
        return report_error(f"{report.io_error}; {_kept(folder)}; {_io_hint(report.io_error)}")
    if report.interrupted:
        kept = sorted(k for k, _ in _episodes(folder))
        print(
            f"interrupted ({'SIGTERM' if report.terminated else 'Ctrl-C'}): the episodes in "
            f"progress were discarded; {len(kept)} finished episode(s) kept in {folder} "
            f"({format_indices(kept)}){_missing(kept, num_episodes)}; rerun the same command "
            "to continue",
            file=sys.stderr,
        )
        return EXIT_TERMINATED if report.terminated else EXIT_INTERRUPTED
    episodes = _episodes(folder)
    total_bytes = sum(path.stat().st_size for _, path in episodes)
    print(
        f"recorded {len(saved)} episode(s) in {wall:.1f} s, {format_size(report.saved_bytes)}; "
        f"dataset: {len(episodes)} episode(s), {format_size(total_bytes)} in {folder}"
    )
    noun, total = ("attempts", report.attempts) if args.skip_failed else ("episodes", len(saved))
    why = failure_summary(report.failed, total, noun, episode_len, minimum_len)
    if args.skip_failed:
        print(f"attempts: {report.attempts} (bound {max_attempts})")
        if len(saved) < len(plan.indices):
            print(f"Success: {report.successes} / {report.attempts}")
            raise UserError(
                f"only {len(saved)} successful episodes after {report.attempts} "
                f"attempts ({why}); check the task or rerun to continue"
            )
        why = why and f"{why} (discarded)"
    print(f"Success: {report.successes} / {total}" + (f"; {why}" if why else ""))
    failed = report.failed_indices
    if failed and not args.skip_failed:
        print(
            f"failed: {format_indices(failed)} kept with success=False; rerunning the same "
            "command records them again (or pass --skip_failed to keep only successes)",
            file=sys.stderr,
        )
        return EXIT_FAILED_EPISODES
    return 0


def _missing(kept: list[int], num_episodes: int) -> str:
    missing = sorted(set(range(num_episodes)) - set(kept))
    return f"; missing: {format_indices(missing)}" if missing and kept else ""


def _episodes(folder: Path) -> list[tuple[int, Path]]:
    from trossen_arm_mujoco.data.reader import list_episodes

    return list_episodes(folder, missing_ok=True)


def _kept(folder: Path) -> str:
    """``"complete episodes: 0..1 in <folder>"`` (what survives an I/O error)."""
    if not folder.is_dir():
        return "complete episodes: none (the folder is gone)"
    kept = sorted(k for k, _ in _episodes(folder))
    if not kept:
        return "complete episodes: none"
    return f"complete episodes: {format_indices(kept)} in {folder}"


def _io_hint(exc: EpisodeIOError) -> str:
    import errno

    if exc.folder_missing:
        return "rerun to record again"
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return "free disk space or choose another --root_dir, then rerun to continue"
    if exc.errno in (errno.EAGAIN, errno.ENOENT):
        return (
            "another program changed or holds files in the folder; stop it (or use another "
            "--data_dir), then rerun to continue"
        )
    return "check the folder's permissions or choose another --root_dir, then rerun to continue"
