"""Atomic file writes: a reader sees the old file or the complete new one, never a part.

Every file the package writes goes through here: the content goes to a hidden temporary
sibling ``.<name>.tmp``, is fsynced and renamed onto the final name, and the folder is
fsynced; on any error, Ctrl-C and SIGTERM included, the temporary file is removed.
:func:`atomic_path` yields the temporary path to write; :func:`publish` is the last step
alone; :func:`deferred_signals` holds signals over steps that must finish together;
:func:`folder_lock` and :func:`remove_stale_temps` keep one writer per folder and clean up
after a killed run; :func:`check_writable_dir` and :func:`folder_problem` check an output
folder before work starts (one line naming the flag).

Docs: docs/troubleshooting.md.
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import signal
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from trossen_arm_mujoco.errors import UserError, describe_os_error, os_error_hint
from trossen_arm_mujoco.stopping import NOTE, TERMINATING_SIGNALS, StopSignals

__all__ = [
    "DEFERRED_SIGNALS",
    "PROBE_PREFIX",
    "FolderBusyError",
    "PathLike",
    "atomic_path",
    "check_folder_path",
    "check_writable_dir",
    "deferred_signals",
    "folder_lock",
    "folder_problem",
    "fsync_dir",
    "fsync_file",
    "publish",
    "remove_stale_temps",
    "temp_path",
    "write_bytes",
    "write_text",
]

PathLike = str | os.PathLike[str]

#: Signals held by :func:`deferred_signals`: Ctrl-C and those that would end the process.
DEFERRED_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, *TERMINATING_SIGNALS)


class FolderBusyError(OSError):
    """Another process holds the lock of the folder (:func:`folder_lock`)."""


def temp_path(path: PathLike) -> Path:
    """The temporary sibling used while writing ``path``: ``<folder>/.<name>.tmp``."""
    path = Path(path)
    return path.with_name(f".{path.name}.tmp")


def fsync_file(path: PathLike) -> None:
    """Flush a closed file's content to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(folder: PathLike) -> None:
    """Persist renames in ``folder`` (best effort: not every platform can open a folder)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def publish(src: PathLike, dst: PathLike, *, overwrite: bool = False, fsync: bool = True) -> Path:
    """Move the complete file ``src`` onto ``dst`` in one step (same file system).

    Args:
        src: the finished file (closed), normally ``temp_path(dst)``.
        dst: the final name.
        overwrite: replace an existing ``dst``; when False an existing ``dst`` is never
            touched, even one that appears while this runs (hard link, then unlink).
        fsync: flush ``src`` before the rename and the folder after it.

    Returns:
        ``dst`` as a Path.

    Raises:
        FileExistsError: ``dst`` exists and ``overwrite`` is False; ``src`` is left in
            place (the caller decides: :func:`atomic_path` removes it).
    """
    src, dst = Path(src), Path(dst)
    if fsync:
        fsync_file(src)
    with deferred_signals():  # the link and the unlink of src go together
        _move(src, dst, overwrite)
    if fsync:
        fsync_dir(dst.parent)
    return dst


def _move(src: Path, dst: Path, overwrite: bool) -> None:
    if overwrite:
        os.replace(src, dst)
    else:
        try:
            os.link(src, dst)  # fails if dst exists: no clobbering, even in a race
        except FileExistsError:
            raise FileExistsError(f"{dst} already exists; refusing to overwrite it") from None
        except OSError:  # a file system without hard links
            if dst.exists():
                raise FileExistsError(f"{dst} already exists; refusing to overwrite it") from None
            os.replace(src, dst)
        else:
            src.unlink()


@contextmanager
def atomic_path(path: PathLike, *, overwrite: bool = True, fsync: bool = True) -> Iterator[Path]:
    """Write ``path`` atomically: yields the temporary path to write (and close) inside the
    block; on normal exit it is published onto ``path``, on any error it is removed.

    Example::

        with atomic_path(out / "plot.png") as tmp:
            fig.savefig(tmp, format="png")  # give the format: tmp ends in ".tmp"

    Args:
        path: the final file; its folder must exist.
        overwrite: replace an existing file (default); False raises FileExistsError
            at publish time and leaves the existing file untouched.
        fsync: flush the file and the folder (see :func:`publish`).
    """
    path = Path(path)
    tmp = temp_path(path)
    try:
        yield tmp
        publish(tmp, path, overwrite=overwrite, fsync=fsync)
    finally:
        with deferred_signals():  # a second Ctrl-C must not skip the cleanup
            tmp.unlink(missing_ok=True)


def write_bytes(path: PathLike, data: bytes, *, overwrite: bool = True) -> Path:
    """Atomically write ``data`` to ``path`` (see :func:`atomic_path`); returns ``path``.

    Args:
        path: the file to write.
        data: its content.
        overwrite: replace a file already there (False: ``FileExistsError`` if one exists).
    """
    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: PathLike, text: str, *, overwrite: bool = True) -> Path:
    """Atomically write ``text`` (UTF-8) to ``path`` (see :func:`atomic_path`).

    Args:
        path: the file to write.
        text: its content.
        overwrite: replace a file already there (False: ``FileExistsError`` if one exists).
    """
    return write_bytes(path, text.encode("utf-8"), overwrite=overwrite)


@contextmanager
def deferred_signals() -> Iterator[None]:
    """Hold SIGINT, SIGTERM and the other signals that would end the process until the block
    ends, then deliver them to the handlers that were in place (a ``KeyboardInterrupt``
    raised at the end of the block, say).

    For a few steps that must not be cut in half: a rename and the cleanup that goes with
    it, the removal of a temporary file. Only the main thread handles signals; elsewhere
    (and for a signal that was ignored) this does nothing.
    """
    holder = StopSignals(NOTE, DEFERRED_SIGNALS)  # noted only, while the block runs
    try:
        with holder.handling():
            yield
    finally:
        for sig in dict.fromkeys(holder.late):  # once each, in arrival order
            signal.raise_signal(sig)


@contextmanager
def folder_lock(folder: PathLike) -> Iterator[Path]:
    """Hold an exclusive lock on ``folder`` (which must exist) for the block.

    An advisory ``flock`` on the folder itself, so nothing is left behind; the OS releases
    it when the process dies, even by SIGKILL. Where ``flock`` is missing (Windows) the
    block runs unlocked.

    Raises:
        FolderBusyError: another process holds the lock.
    """
    folder = Path(folder)
    try:
        import fcntl
    except ImportError:  # no flock on this platform
        yield folder
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusyError(f"{folder} is in use by another process") from None
        yield folder
    finally:
        os.close(fd)  # releases the lock


def remove_stale_temps(folder: PathLike, final_name: str | re.Pattern[str]) -> list[Path]:
    """Delete the temporary siblings (:func:`temp_path`) that a killed run left in ``folder``:
    those whose final name matches ``final_name`` (a regular expression matched whole).

    Only call it while holding the folder (:func:`folder_lock`): a temporary file of a run
    in progress is not stale. Folders are removed with their content. Returns the deleted
    paths (none when ``folder`` does not exist or cannot be listed).
    """
    pattern = re.compile(final_name)
    removed = []
    try:
        entries = sorted(Path(folder).iterdir())
    except OSError:
        return []
    for path in entries:
        name = path.name
        if not (name.startswith(".") and name.endswith(".tmp")):
            continue
        if not pattern.fullmatch(name[1 : -len(".tmp")]):
            continue
        with deferred_signals():
            try:
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path)
                else:
                    path.unlink()
            except FileNotFoundError:
                pass
            except OSError:  # read-only: the write that follows says so
                continue
        removed.append(path)
    return removed


#: Prefix of the hidden file :func:`check_writable_dir` creates and removes.
PROBE_PREFIX = ".write_test."


def folder_problem(path: PathLike) -> tuple[Path, str] | None:
    """Why ``path`` cannot be (or become) a folder, looking at it and its parents from the
    top: ``(the path at fault, "is a file, not a folder")``, ``"is a symlink loop"`` or
    ``"is a link to a missing path (<target>)"``; None when every existing part is a folder
    (missing parts are fine: they can be created). Follows symlinks that work."""
    path = Path(os.path.abspath(Path(path).expanduser()))
    for part in [*reversed(path.parents), path]:
        try:
            info = os.lstat(part)
        except FileNotFoundError:
            return None  # this part and those below it are missing: they can be created
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                return part, "is a symlink loop"
            return None  # not this function's to judge: the write probe says what fails
        if stat.S_ISLNK(info.st_mode):
            try:
                info = os.stat(part)
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    return part, "is a symlink loop"
                if exc.errno in (errno.ENOENT, errno.ENOTDIR):
                    return part, f"is a link to a missing path ({os.readlink(part)})"
                return None
        if stat.S_ISREG(info.st_mode):
            return part, "is a file, not a folder"
        if not stat.S_ISDIR(info.st_mode):
            return part, "is not a folder"
    return None


def _problem_text(path: Path, at: Path, what: str, flag: str) -> str:
    """``<why>; <what to do>`` for :func:`folder_problem`'s answer."""
    itself = at == Path(os.path.abspath(path))
    if what.startswith("is a file"):
        if itself:
            return "it is a file; give a folder (a missing one is created), or move the file away"
        return f"a file is in the way ({at}); move it away or choose another {flag}"
    where = "it" if itself else str(at)
    if what.startswith("is a symlink loop"):
        return f"{where} {what}; fix or remove the link, or choose another {flag}"
    if what.startswith("is a link to a missing path"):
        return (
            f"{where} {what}; create the folder it points to, fix the link, or choose "
            f"another {flag}"
        )
    return f"{where} {what}; choose another {flag}"


def check_folder_path(path: PathLike, flag: str) -> None:
    """Raise a one-line UserError naming ``flag`` when ``path`` cannot be a folder
    (:func:`folder_problem`: a part of it is a file, a symlink loop or a link to a missing
    path); nothing is created or written (:func:`check_writable_dir` does both checks)."""
    path = Path(path).expanduser()
    problem = folder_problem(path)
    if problem is not None:
        raise UserError(f"cannot write to {flag} {path}: {_problem_text(path, *problem, flag)}")


def check_writable_dir(path: PathLike, flag: str) -> Path:
    """Check, before any work, that a command can write files in the folder ``path``.

    For real: the folder and its missing parents are created (as the command would create
    them), a hidden file of this process's own (``.write_test.<pid>-<random>``) is created
    and removed in it, and the folders this check created are removed again, so that
    nothing is left behind; the command creates its folder itself when it starts.

    Args:
        path: the output folder (``~`` expanded; relative to the current folder).
        flag: the command-line flag that chose it (``"--output"``), named in the error.

    Returns:
        ``path`` as a Path (``~`` expanded).

    Raises:
        UserError: one line, ``cannot write to <flag> <path>: <why>; <what to do>``: a
            part of the path is a file, a symlink loop or a link to a missing path, or
            the file system refuses (read-only, permissions, full, no such folder).
    """
    path = Path(path).expanduser()
    check_folder_path(path, flag)
    created: list[Path] = []
    try:
        for folder in [*reversed(path.parents), path]:
            if not folder.is_dir():
                folder.mkdir()
                created.append(folder)
        probe = path / f"{PROBE_PREFIX}{os.getpid()}-{secrets.token_hex(4)}"
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"\0")
        finally:
            os.close(fd)
            with deferred_signals():
                probe.unlink(missing_ok=True)
    except OSError as exc:
        raise UserError(
            f"cannot write to {flag} {path}: {describe_os_error(exc)}; {os_error_hint(exc, flag)}"
        ) from None
    finally:
        for folder in reversed(created):
            try:
                folder.rmdir()
            except OSError:
                pass
    return path
