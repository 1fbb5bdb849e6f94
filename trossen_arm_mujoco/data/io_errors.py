"""Errors of writing an episode file, and discarding a file safely.

:class:`EpisodeWriteError`: invalid data handed to the writer, or a refused commit (the
final file appeared meanwhile, the written file does not read back). :class:`EpisodeIOError`:
write failures the file system causes, as one-line errors.

A full disk (ENOSPC), a read-only (EROFS) or unwritable (EACCES) folder, or a folder removed
during a run surface from h5py as ``OSError`` (sometimes ``RuntimeError``) with HDF5's
multi-line text; :func:`io_error` turns them into an :class:`EpisodeIOError` naming the file
and the cause. :func:`discard_file` closes a file that HDF5 can no longer flush.

Docs: docs/datasets.md, docs/troubleshooting.md.
"""

from __future__ import annotations

import errno
import os
import re
from pathlib import Path

import h5py

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "IO_ERRORS",
    "EpisodeIOError",
    "EpisodeWriteError",
    "discard_file",
    "folder_io_error",
    "io_error",
    "os_error_number",
]


class EpisodeWriteError(UserError):
    """Invalid data handed to the episode writer, or a refused write."""


class EpisodeIOError(UserError):
    """The file system refused to write the episode (disk full, read-only or unwritable
    folder, folder removed during the run). The temporary file was removed.

    Args:
        message: the one-line error.
        number: the OS error number, when known.
        folder_missing: the episode's folder no longer exists.

    Attributes:
        errno: the OS error number when known (``errno.ENOSPC``...), else None.
        folder_missing: True when the episode's folder no longer exists.
    """

    def __init__(self, message: str, number: int | None = None, folder_missing: bool = False):
        super().__init__(message)
        self.errno = number
        self.folder_missing = folder_missing

    def __reduce__(self):  # keep the attributes across processes (worker pools)
        return (type(self), (str(self), self.errno, self.folder_missing))


#: Errors h5py and the OS raise for a refused write (h5py reports some as RuntimeError).
IO_ERRORS = (OSError, RuntimeError)


def os_error_number(exc: BaseException) -> int | None:
    """The errno of ``exc``: its ``errno`` attribute, else the ``errno = N`` that h5py puts
    in its messages, else None."""
    number = getattr(exc, "errno", None)
    if isinstance(number, int) and number:
        return number
    match = re.search(r"errno = (\d+)", str(exc))
    return int(match.group(1)) if match else None


def _cause(exc: BaseException) -> str:
    number = os_error_number(exc)
    if number:
        return f"{os.strerror(number)} ({errno.errorcode.get(number, number)})"
    return " ".join(str(exc).split()) or type(exc).__name__


def io_error(path: Path, exc: BaseException) -> EpisodeIOError:
    """The one-line :class:`EpisodeIOError` for a failed write of file ``path``."""
    folder = path.parent
    if not folder.is_dir():
        return EpisodeIOError(
            f"cannot write {path.name}: the folder {folder} was removed during the run",
            os_error_number(exc),
            folder_missing=True,
        )
    return EpisodeIOError(
        f"cannot write {path.name} in {folder}: {_cause(exc)}", os_error_number(exc)
    )


def folder_io_error(folder: Path, exc: BaseException) -> EpisodeIOError:
    """The one-line :class:`EpisodeIOError` for a failed change to ``folder``."""
    if not folder.is_dir():
        return EpisodeIOError(
            f"the folder {folder} was removed during the run",
            os_error_number(exc),
            folder_missing=True,
        )
    return EpisodeIOError(f"cannot write to {folder}: {_cause(exc)}", os_error_number(exc))


def discard_file(file: h5py.File) -> None:
    """Close an HDF5 file that is being deleted, without writing to its disk again.

    After a refused write (disk full) HDF5 cannot flush the file, so closing it fails, and
    a file left open makes the interpreter crash at exit. The file's descriptor is first
    pointed at ``/dev/null`` (POSIX), where the final flush succeeds; never raises.
    """
    if os.name == "posix":
        try:
            fd = file.id.get_vfd_handle()
            null = os.open(os.devnull, os.O_RDWR)
            try:
                os.dup2(null, fd)
            finally:
                os.close(null)
        except Exception:  # not a plain (sec2) file, or already closed
            pass
    try:
        file.close()
    except Exception:  # best effort: the file is deleted anyway
        pass
