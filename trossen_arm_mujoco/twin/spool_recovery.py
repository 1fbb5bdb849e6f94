"""Spools left by dead processes: found, read, and published as the episodes they hold.

A serve spool (:mod:`.episode_spool`) whose process no longer runs is an episode that was
never published. :func:`recover_spools`, called by the next ``serve --record`` into that
folder under the dataset lock, publishes each as the folder's next episode through the
writer (validated) and only then deletes it; one whose episode was already published (the
same ``recording_id``) or that holds no step is deleted, and one that cannot be published is
kept, with a line saying why and how to recover it. :func:`read_spool` reads a spool's whole
steps (a torn last record is ignored).

Docs: docs/cli/serve.md.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import describe_os_error
from trossen_arm_mujoco.twin.episode_spool import (
    HEADER_LENGTH,
    MAGIC,
    NUMERIC,
    RECORDING_ID_ATTR,
    SpoolLayout,
    read_step_images,
    spool_pid,
    write_episode,
)

__all__ = [
    "Recovery",
    "SpoolContents",
    "SpoolFormatError",
    "read_spool",
    "recover_spools",
    "stale_spools",
]


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, another user's
        return True
    return True


def stale_spools(folder: Path) -> list[Path]:
    """Serve spools in ``folder`` whose process no longer runs, oldest first."""
    try:
        paths = [
            p
            for p in Path(folder).glob(".serve_spool.*.tmp")
            if (pid := spool_pid(p)) is not None and not _alive(pid)
        ]
        return sorted(paths, key=lambda p: (p.stat().st_mtime, p.name))
    except OSError:  # folder gone or unreadable: nothing to recover here
        return []


@dataclass
class SpoolContents:
    """What a spool left by a dead process holds (:func:`read_spool`)."""

    path: Path
    meta: dict[str, Any]
    rows: dict[str, list[np.ndarray | float]]
    layout: SpoolLayout | None
    offset: int
    torn_bytes: int  # bytes of an unfinished last record, ignored

    @property
    def steps(self) -> int:
        """Number of steps in the spool."""
        return len(self.rows["reward"])


class SpoolFormatError(ValueError):
    """A file named like a spool that is not one of this version, or whose header is
    damaged: no episode can be made of it."""


def read_spool(path: Path) -> SpoolContents:
    """The whole steps of a spool file (numbers; frames are read when published).

    Raises:
        SpoolFormatError: not a spool of this format (or its header is damaged).
        OSError: unreadable.
    """
    rows: dict[str, list[Any]] = {k: [] for k in NUMERIC}
    with open(path, "rb") as f:
        head = f.read(len(MAGIC) + HEADER_LENGTH.size)
        if not head:  # created, no step yet
            return SpoolContents(Path(path), {}, rows, None, 0, 0)
        if head.startswith(b"\x89HDF"):
            raise SpoolFormatError(
                "a spool of an older version, holding camera frames only (the states and "
                "actions were in its process's memory)"
            )
        if len(head) < len(MAGIC) + HEADER_LENGTH.size or not head.startswith(MAGIC):
            raise SpoolFormatError("not a spool file of this version (unknown header)")
        length = HEADER_LENGTH.unpack(head[len(MAGIC) :])[0]
        raw = f.read(length)
        if len(raw) < length:  # killed while writing the header: no step was written
            return SpoolContents(Path(path), {}, rows, None, 0, len(raw))
        try:
            header = json.loads(raw)
            layout = SpoolLayout(
                {k: int(header["widths"][k]) for k in NUMERIC},
                [str(c) for c in header["camera_names"]],
                int(header["height"]),
                int(header["width"]),
            )
        except (ValueError, KeyError, TypeError) as exc:
            raise SpoolFormatError(f"damaged header ({exc})") from None
        offset = len(head) + length
        size = os.fstat(f.fileno()).st_size
        whole, torn = divmod(max(0, size - offset), layout.record_bytes)
        for t in range(whole):
            f.seek(offset + t * layout.record_bytes)
            values = np.frombuffer(f.read(8 * layout.numbers), dtype=np.float64)
            start = 0
            for k in NUMERIC:
                part = values[start : start + layout.widths[k]].copy()
                start += layout.widths[k]
                rows[k].append(float(part[0]) if k == "reward" else part)
    meta = header.get("meta") if isinstance(header.get("meta"), dict) else {}
    return SpoolContents(Path(path), meta, rows, layout, offset, torn)


@dataclass
class Recovery:
    """What :func:`recover_spools` did with one spool."""

    spool: Path
    episode: Path | None = None  # the episode file it became
    steps: int = 0
    problem: str = ""  # why it was kept (empty: published, or held nothing)


def recover_spools(
    folder: Path, next_index: Callable[[], int], say: Callable[[str], None] = print
) -> list[Recovery]:
    """Publish the episodes that spools of dead processes in ``folder`` hold (call it holding
    the folder's lock): each as the folder's next episode (``next_index()``), through the
    writer (validated); the spool is deleted only then. A spool that holds no step, or
    whose episode was already published (same ``recording_id``), is deleted; one that
    cannot be published is kept, with one line through ``say`` saying why and how to
    recover it. Returns one :class:`Recovery` per spool found.

    Args:
        folder: the dataset folder (its lock held by the caller).
        next_index: gives the folder's next episode index.
        say: gets one line per spool recovered or kept.
    """
    from trossen_arm_mujoco.data.reader import episode_path

    done = []
    for path in stale_spools(folder):
        result = Recovery(path)
        done.append(result)
        try:
            contents = read_spool(path)
            result.steps = contents.steps
            if contents.steps == 0 or _already_published(folder, contents.meta):
                path.unlink(missing_ok=True)
                continue
            index = next_index()
            result.episode = _publish_contents(contents, episode_path(folder, index))
        except Exception as exc:  # kept: say where its data is and what to do
            result.episode = None
            text = describe_os_error(exc) if isinstance(exc, OSError) else str(exc)
            result.problem = " ".join(text.split())
            if isinstance(exc, SpoolFormatError):
                todo = "it cannot become an episode; move it out of the folder to give it up"
            else:
                todo = (
                    "fix that and run serve --record into this folder again to recover "
                    "it (or move it out of the folder to give it up)"
                )
            say(
                f"warning: {path} was left by a serve that stopped before writing its "
                f"episode and is kept, not recovered: {result.problem}; {todo}"
            )
            continue
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass
        say(
            f"{result.episode.name}: recovered {contents.steps} steps "
            f"({contents.steps * float(contents.meta.get('attrs', {}).get('dt', 0.02)):.2f} s) "
            f"that a stopped serve left in {path.name}"
        )
    return done


def _already_published(folder: Path, meta: Mapping[str, Any]) -> bool:
    """Whether an episode of ``folder`` carries the spool's ``recording_id``."""
    from trossen_arm_mujoco.data.reader import episode_path

    attrs = meta.get("attrs") if isinstance(meta.get("attrs"), dict) else {}
    rid, index = attrs.get(RECORDING_ID_ATTR), meta.get("index")
    if not rid or not isinstance(index, int):
        return False
    candidate = episode_path(folder, index)
    if not candidate.is_file():
        return False
    try:
        import h5py

        with h5py.File(candidate, "r") as f:
            found = f.attrs.get(RECORDING_ID_ATTR)
    except (OSError, ValueError):
        return False
    if isinstance(found, bytes):
        found = found.decode()
    return found == rid


def _publish_contents(contents: SpoolContents, path: Path) -> Path:
    layout = contents.layout
    assert layout is not None
    meta = contents.meta
    attrs: dict[str, Any] = dict(meta.get("attrs") or {})
    rewards = np.asarray(contents.rows["reward"], dtype=np.float64)
    top = float(meta.get("task_max_reward", 1.0))
    final, best = float(rewards[-1]), float(rewards.max())
    attrs.update(
        success=bool(final >= top),
        final_reward=final,
        max_reward=best,
        end_reason="recovered: serve stopped before writing it",
        recovered_from=contents.path.name,
    )
    attrs.setdefault("task_name", "unknown")
    attrs.setdefault("seed", 0)
    compression = str(meta.get("compression", "gzip"))
    fd = os.open(contents.path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        return write_episode(
            path,
            contents.rows,
            lambda t: read_step_images(fd, layout, t, contents.offset),
            layout.camera_names,
            layout.height,
            layout.width,
            attrs,
            compression,
        )
    finally:
        os.close(fd)
