"""One writer per dataset folder: an OS lock on ``<folder>/.trossen.lock``.

A recording run holds :class:`DatasetLock` from before it looks at the folder until its last
file is in place. The lock is ``flock(2)``, so the OS releases it when the holder exits for
any reason (``kill -9`` included); the file holds the holder's pid and host, for the one-line
error a second run gives (:func:`locked_message`). The file is removed on release; a waiter
that gets a removed file tries again on the new one. Inside one process the lock is
reentrant (the command line takes it, the recorder's ``run`` nests inside).

Docs: docs/cli/record.md, docs/troubleshooting.md.
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
from collections.abc import Callable
from pathlib import Path

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "LOCK_FILE",
    "DatasetLock",
    "DatasetLockedError",
    "holder_text",
    "is_locked_here",
    "locked_message",
    "read_holder",
]

#: Name of the lock file inside a dataset folder (hidden; never an episode name).
LOCK_FILE = ".trossen.lock"

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: no flock, runs are not locked
    fcntl = None  # type: ignore[assignment]


class DatasetLockedError(UserError):
    """Another process holds the dataset folder's lock.

    Args:
        message: the one-line error (:func:`locked_message`).
        pid: the holder's pid.
        host: the holder's host name.

    Attributes:
        pid: the holder's pid as its lock file says (None when unreadable).
        host: the holder's host name (None when unreadable).
    """

    def __init__(self, message: str, pid: int | None = None, host: str | None = None):
        super().__init__(message)
        self.pid = pid
        self.host = host


def read_holder(folder: str | os.PathLike[str]) -> tuple[int | None, str | None]:
    """``(pid, host)`` written in ``folder``'s lock file; ``(None, None)`` when there is no
    readable one. Says nothing about whether that process still holds the lock."""
    try:
        text = (Path(folder) / LOCK_FILE).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None, None
    parts = text.split()
    pid = int(parts[0]) if parts and parts[0].isdigit() else None
    host = parts[1] if len(parts) > 1 else None
    return pid, host


def holder_text(pid: int | None, host: str | None) -> str:
    """``"pid 4242"``, ``"pid 4242 on host other"`` (another host), or ``"pid unknown"``."""
    text = f"pid {pid}" if pid is not None else "pid unknown"
    if host and host != socket.gethostname():
        text += f" on host {host}"
    return text


def locked_message(folder: Path, pid: int | None, host: str | None) -> str:
    """The one-line error for a locked dataset folder, with how to go on.

    Args:
        folder: the dataset folder.
        pid: the holder's pid (None when unknown).
        host: the holder's host name (None when unknown).
    """
    return (
        f"another record run ({holder_text(pid, host)}) is writing to {folder}; wait for it "
        "to finish (or pass --wait), or choose another --data_dir"
    )


#: Locks this process holds: folder key -> [pid of the holder process, fd, depth].
_HELD: dict[str, list[int]] = {}
_HELD_GUARD = threading.Lock()


def _key(folder: Path) -> str:
    return os.path.realpath(folder)


class DatasetLock:
    """Exclusive lock on a dataset folder for one writing run (a context manager).

    Args:
        folder: the dataset folder; it must exist.
        wait: when another process holds the lock, wait for it (``on_wait`` is called once
            with the holder's pid and host) instead of raising :class:`DatasetLockedError`.
        on_wait: called once before waiting, e.g. to print a line.

    Raises (from :meth:`acquire`):
        DatasetLockedError: the folder is locked by another process and ``wait`` is False.
        UserError: the lock file cannot be created (unwritable folder).
    """

    def __init__(
        self,
        folder: str | os.PathLike[str],
        wait: bool = False,
        on_wait: Callable[[int | None, str | None], None] | None = None,
    ) -> None:
        self.folder = Path(folder).expanduser()
        self.path = self.folder / LOCK_FILE
        self.wait = wait
        self.on_wait = on_wait
        self._acquired = False

    def __enter__(self) -> DatasetLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    @property
    def held(self) -> bool:
        """Whether this object holds the lock now."""
        return self._acquired

    def acquire(self) -> DatasetLock:
        """Take the lock (waiting for it when ``wait``), or a ``DatasetLockedError``
        naming its holder; taking it again in the same process only counts up. Returns ``self``."""
        if self._acquired:
            return self
        key = _key(self.folder)
        with _HELD_GUARD:
            entry = _HELD.get(key)
            if entry is not None and entry[0] == os.getpid():
                entry[2] += 1
                self._acquired = True
                return self
        fd = self._lock_fd() if fcntl is not None else -1
        with _HELD_GUARD:
            _HELD[key] = [os.getpid(), fd, 1]
        self._acquired = True
        return self

    def _open(self) -> int:
        cloexec = getattr(os, "O_CLOEXEC", 0)
        try:
            return os.open(self.path, os.O_RDWR | os.O_CREAT | cloexec, 0o644)
        except PermissionError:  # another user's lock file: a read-only handle locks too
            with contextlib.suppress(OSError):
                return os.open(self.path, os.O_RDONLY | cloexec)
            raise UserError(
                f"cannot write to {self.folder}: Permission denied; choose another --root_dir"
            ) from None
        except OSError as exc:
            raise UserError(
                f"cannot write to {self.folder}: {exc.strerror or exc}; choose another --root_dir"
            ) from None

    def _lock_fd(self) -> int:
        waited = False
        while True:
            fd = self._open()
            try:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    pid, host = read_holder(self.folder)
                    if not self.wait:
                        raise DatasetLockedError(
                            locked_message(self.folder, pid, host), pid, host
                        ) from None
                    if not waited and self.on_wait is not None:
                        self.on_wait(pid, host)
                    waited = True
                    fcntl.flock(fd, fcntl.LOCK_EX)  # Ctrl-C / SIGTERM still end the wait
                except OSError:  # no locking on this file system (some network mounts)
                    return fd
                if self._is_current(fd):
                    self._write_holder(fd)
                    return fd
            except BaseException:
                os.close(fd)
                raise
            os.close(fd)  # the holder removed the file as we got it: lock the new one

    def _is_current(self, fd: int) -> bool:
        """Whether ``fd`` is still the file at :attr:`path` (not one its holder removed)."""
        try:
            here, there = os.fstat(fd), os.stat(self.path)
        except OSError:
            return False
        return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)

    def _write_holder(self, fd: int) -> None:
        text = f"{os.getpid()} {socket.gethostname()}\n".encode()
        with contextlib.suppress(OSError):  # the pid is for messages only
            os.ftruncate(fd, 0)
            os.pwrite(fd, text, 0)

    def release(self) -> None:
        """Release the lock (the outermost release in this process removes the file)."""
        if not self._acquired:
            return
        self._acquired = False
        key = _key(self.folder)
        with _HELD_GUARD:
            entry = _HELD.get(key)
            if entry is None or entry[0] != os.getpid():
                return
            entry[2] -= 1
            if entry[2] > 0:
                return
            del _HELD[key]
        fd = entry[1]
        if fd < 0:
            return
        # Remove the file while still holding it: a run waiting on this file then sees that
        # it is no longer the current one and locks the next one instead.
        with contextlib.suppress(OSError):
            if self._is_current(fd):
                self.path.unlink()
        os.close(fd)


def is_locked_here(folder: str | os.PathLike[str]) -> bool:
    """Whether this process holds ``folder``'s lock."""
    entry = _HELD.get(_key(Path(folder).expanduser()))
    return entry is not None and entry[0] == os.getpid()
