"""What a recording run records in a folder that may already hold episodes.

:func:`plan_run` reads every episode file with the reader's validation; an unreadable file,
or one recorded with other settings (naming the flags that differ), stops the run. A
successful episode (or one whose success is not recorded) is kept; a failed one is recorded
again; a missing index below ``num_episodes`` is recorded. Each episode is one attempt whose
seed derives from the run seed and the attempt number: a missing index ``k`` gets attempt
``k`` when no file used it (so a resumed run gives the files of an uninterrupted one), a
failed index a fresh attempt after every attempt a file uses; with ``skip_failed`` attempts
run from the first one no file used.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trossen_arm_mujoco.data.reader import EpisodeError, list_episodes, load_episode
from trossen_arm_mujoco.data.schema import EPISODE_FILE_RE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.camera_crop import crop_texts

__all__ = ["RunPlan", "check_episode_names", "format_indices", "plan_run", "settings_differences"]

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.pipeline import RecordSettings


@dataclass
class RunPlan:
    """Which episode indices a run records, with which attempts.

    Attributes:
        indices: episode indices to record, ascending.
        attempts: the attempt recorded as each of ``indices`` (without ``skip_failed``).
        first_attempt: first attempt no file used (``skip_failed`` runs attempts from it).
        existing: complete episodes kept as they are.
        failed: episodes that failed before; among ``indices``, replaced when recorded.
    """

    indices: list[int]
    attempts: list[int]
    first_attempt: int
    existing: list[int] = field(default_factory=list)
    failed: list[int] = field(default_factory=list)
    overwrite: bool = False

    @property
    def first_index(self) -> int:
        """The first index recorded (one past the last episode when there is none)."""
        if self.indices:
            return self.indices[0]
        return max(self.existing, default=-1) + 1

    @property
    def gaps(self) -> list[int]:
        """Indices below the highest existing episode that hold no file."""
        present = set(self.existing) | set(self.failed)
        return [k for k in range(max(present, default=-1)) if k not in present]

    def replaces(self, index: int) -> bool:
        """Whether recording ``index`` replaces a file (a failed episode, or ``overwrite``)."""
        return self.overwrite or index in self.failed


def format_indices(indices: list[int], noun: str = "episode") -> str:
    """``"episodes 0..2, 5, 7..8"``, ``"episode 3"``, ``"none"``: runs of consecutive
    indices, so that a gap shows."""
    ks = sorted(set(indices))
    if not ks:
        return "none"
    runs: list[str] = []
    start = prev = ks[0]
    for k in [*ks[1:], None]:
        if k is not None and k == prev + 1:
            prev = k
            continue
        runs.append(str(start) if start == prev else f"{start}..{prev}")
        if k is not None:
            start = prev = k
    plural = len(ks) > 1
    return f"{noun}{'s' if plural else ''} {', '.join(runs)}"


def _flag_value(flag: str, value: Any) -> str:
    if flag == "--cam_names":
        return ",".join(value) or "none"
    if flag == "--crop":
        return value or "none"
    if isinstance(value, bool):
        return "set" if value else "not set"
    return str(value)


def settings_differences(episode, settings: RecordSettings) -> list[str]:
    """``["--seed 0 (this run: 5)", ...]``: what differs between how ``episode`` was
    recorded and ``settings``; attributes the file lacks are not compared."""
    attrs = episode.attrs
    checks: list[tuple[str, Any, Any]] = [
        ("--task_name", attrs.get("task_name"), settings.task_name),
        ("--seed", attrs.get("base_seed"), settings.base_seed),
        ("--episode_len", episode.num_steps, settings.episode_len),
        ("--cam_names", tuple(episode.camera_names), tuple(settings.cam_names)),
        ("--inject_noise", attrs.get("inject_noise"), settings.inject_noise),
        ("--visual", attrs.get("visual"), settings.visual),
    ]
    if "schema_version" in attrs:  # this package's files say whether they were randomized
        checks.append(("--randomize", "randomization" in attrs, settings.randomize))
    if "shadows" in attrs:
        checks.append(("--no_shadows", not attrs["shadows"], not settings.shadows))
    if "antialias" in attrs:
        checks.append(("--no_antialias", not attrs["antialias"], not settings.antialias))
    if "schema_version" in attrs:  # files of this package name their crops (none: "")
        checks.append(("--crop", str(attrs.get("crops", "")), crop_texts(settings.crops)))
    if episode.camera_names and settings.cam_names:
        h, w = episode.image_shapes[episode.camera_names[0]][:2]
        checks.append(("--image_size", f"{h}x{w}", f"{settings.height}x{settings.width}"))
    return [
        f"{flag} {_flag_value(flag, old)} (this run: {_flag_value(flag, new)})"
        for flag, old, new in checks
        if old is not None and old != new
    ]


def _check_readable(folder: Path, found: list[tuple[int, Path]]) -> list:
    episodes, bad = [], []
    for _, path in found:
        try:
            episodes.append(load_episode(path))
        except EpisodeError as exc:
            bad.append((path, exc))
    if bad:
        names = ", ".join(path.name for path, _ in bad)
        verb = "is" if len(bad) == 1 else "are"
        raise UserError(
            f"{names} in {folder} {verb} not a readable episode ({bad[0][1]}); move "
            f"{'it' if len(bad) == 1 else 'them'} out of the folder (or delete "
            f"{'it' if len(bad) == 1 else 'them'}) and rerun: the episode index is recorded "
            "again"
        )
    return episodes


def _entry_problem(path: Path) -> str | None:
    """Why ``path`` (named like an episode) cannot be read or replaced as one, or None."""
    try:
        info = os.lstat(path)
    except OSError:
        return None
    if stat.S_ISLNK(info.st_mode):
        try:
            info = os.stat(path)
        except OSError:
            return f"is a link to a missing path ({os.readlink(path)})"
    if stat.S_ISDIR(info.st_mode):
        return "is a folder, not an episode file"
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file"
    return None


def check_episode_names(folder: Path, num_episodes: int) -> None:
    """Refuse, before any episode is recorded, a folder whose ``episode_<k>.hdf5`` (``k`` below
    ``num_episodes``) is not a file: a folder, a broken link, a device. Such an entry is
    neither read nor replaced (not even with ``--overwrite``), so recording ``k`` would fail.

    Raises:
        UserError: naming the entry, what it is, and ``--data_dir``.
    """
    try:
        names = os.listdir(folder)
    except OSError:
        return  # no folder (yet): nothing in the way
    bad = []
    matches = (EPISODE_FILE_RE.match(name) for name in names)
    for k, name in sorted((int(m.group(1)), m.group(0)) for m in matches if m):
        problem = _entry_problem(folder / name) if k < num_episodes else None
        if problem is not None:
            bad.append(f"{name} {problem}")
    if bad:
        raise UserError(
            f"{'; '.join(bad[:3])}{'; ...' if len(bad) > 3 else ''} (in {folder}); move "
            f"{'it' if len(bad) == 1 else 'them'} out of --data_dir (or delete "
            f"{'it' if len(bad) == 1 else 'them'}) and rerun: record replaces episode files "
            "only, never folders, even with --overwrite"
        )


def plan_run(
    folder: Path,
    num_episodes: int,
    overwrite: bool = False,
    settings: RecordSettings | None = None,
) -> RunPlan:
    """Plan a run that should leave episodes ``0 .. num_episodes - 1`` in ``folder``.

    Args:
        folder: the dataset folder.
        num_episodes: the episodes the run should leave.
        overwrite: record every index afresh (attempt ``k`` as episode ``k``), replacing
            existing files; otherwise every existing episode is validated first.
        settings: the run's settings, compared with every existing episode's; None: not
            compared.

    Raises:
        UserError: an unreadable episode file, one recorded with other settings, or an
            episode name below ``num_episodes`` that is not a file (a folder).
    """
    folder = Path(folder)
    check_episode_names(folder, num_episodes)
    if overwrite:
        return RunPlan(list(range(num_episodes)), list(range(num_episodes)), 0, overwrite=True)
    episodes = _check_readable(folder, list_episodes(folder, missing_ok=True))
    if settings is not None:
        for episode in episodes:
            diffs = settings_differences(episode, settings)
            if diffs:
                raise UserError(
                    f"{folder} holds episodes recorded with other settings than this run "
                    f"({episode.path.name}: {'; '.join(diffs)}); rerun with the dataset's "
                    "flags to continue it, or choose another --data_dir for a new dataset "
                    "(--overwrite replaces its episodes)"
                )
    existing, failed, used = [], [], set()
    for episode in episodes:
        k = episode.index
        assert k is not None
        used.add(int(episode.attrs.get("attempt", k)))
        (failed if episode.attrs.get("success") is False else existing).append(k)
    indices = [k for k in range(num_episodes) if k not in existing]
    natural = [k for k in indices if k not in used and k not in failed]
    fresh = max([*used, *natural], default=-1) + 1
    attempts = []
    for k in indices:
        if k in natural:
            attempts.append(k)
        else:
            attempts.append(fresh)
            fresh += 1
    first_attempt = max(used, default=-1) + 1
    return RunPlan(indices, attempts, first_attempt, existing, failed)
