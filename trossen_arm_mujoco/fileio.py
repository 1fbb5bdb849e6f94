"""Atomic file writes: a reader sees the old file or the complete new one, never a part.

Every file the package writes goes through here: the content is written to a temporary
sibling ``.<name>.tmp`` (same folder, hence same file system, and hidden), fsynced, and
renamed onto the final name; the folder is fsynced so that the rename survives a crash.
On any error, Ctrl-C included, the temporary file is removed.

- :func:`atomic_path`: a context manager yielding the temporary path to write.
- :func:`publish`: the last step alone, for writers that keep a temporary file open across
  many calls (the episode writer) or move a finished file into place (the recorder).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

PathLike = str | os.PathLike[str]


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
    if fsync:
        fsync_dir(dst.parent)
    return dst


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
        tmp.unlink(missing_ok=True)


def write_bytes(path: PathLike, data: bytes, *, overwrite: bool = True) -> Path:
    """Atomically write ``data`` to ``path`` (see :func:`atomic_path`); returns ``path``."""
    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: PathLike, text: str, *, overwrite: bool = True) -> Path:
    """Atomically write ``text`` (UTF-8) to ``path`` (see :func:`atomic_path`)."""
    return write_bytes(path, text.encode("utf-8"), overwrite=overwrite)
