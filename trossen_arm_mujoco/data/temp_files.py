"""Temporary episode files: their unique names, and removing those interrupted runs left.

An episode is written to a hidden sibling of its final file, ``.<name>.<pid>-<random>.tmp``
(unique: two writers never share one), and renamed onto ``<name>`` only when complete (see
``episode_file``). A run that is killed leaves its temporary files behind;
``remove_stale_temp_files`` deletes them, except those of writers that still run.

Docs: docs/troubleshooting.md.
"""

from __future__ import annotations

import os
import re
import secrets
from pathlib import Path

from trossen_arm_mujoco.data.schema import temp_file_name

__all__ = ["remove_stale_temp_files", "unique_temp_path"]

#: Temporary episode files: ``.<final>.tmp`` (older versions) or ``.<final>.<pid>-<hex>.tmp``.
_TEMP_RE = re.compile(r"^\.(?P<final>.+\.hdf5)(?:\.(?P<pid>[0-9]+)-[0-9a-f]+)?\.tmp$")


def unique_temp_path(path: Path) -> Path:
    """A temporary sibling of ``path`` that no other writer uses:
    ``.<name>.<pid>-<random>.tmp`` (hidden, never an episode name)."""
    base = temp_file_name(path.name)  # ".<name>.tmp"
    return path.with_name(f"{base[: -len('.tmp')]}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # this process: its own leftovers are stale when it cleans up
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by another user
        return True
    return True


def remove_stale_temp_files(folder: str | os.PathLike[str]) -> list[Path]:
    """Delete temporary episode files left by interrupted or killed runs in ``folder``.

    Call it only while holding the folder's lock (:mod:`.dataset_lock`), so that no other
    run writes there. A file whose name carries the pid of a process that still runs (a
    writer outside any locked run) is left alone.

    Returns:
        The deleted paths (empty when the folder does not exist).
    """
    folder = Path(folder).expanduser()
    if not folder.is_dir():
        return []
    removed = []
    try:
        for path in sorted(folder.glob(".episode_*.hdf5*.tmp")):
            match = _TEMP_RE.match(path.name)
            if match is None:
                continue
            if match["pid"] is not None and _process_alive(int(match["pid"])):
                continue
            path.unlink(missing_ok=True)
            removed.append(path)
    except OSError:  # folder removed meanwhile, or read-only: nothing to clean
        pass
    return removed
