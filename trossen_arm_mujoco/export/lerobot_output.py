"""The folder a LeRobot export writes: checked before anything is read, built hidden beside
it, published by rename.

- :func:`check_output` (before any episode is read): ``output`` can become the dataset
  folder (missing, empty, or with ``overwrite`` a dataset to replace) and its parent is a
  folder this process can write in.
- :func:`build_folder`: the dataset is built in ``.<output name>.tmp`` next to ``output``,
  locked while in use (``fileio.folder_lock``), and removed on the way out (error, Ctrl-C,
  SIGTERM); the next export empties and reuses one a killed run (SIGKILL) left.
- :func:`publish`: the finished folder is renamed onto ``output``; a dataset already there
  is moved aside to ``.<output name>.old`` first and put back if the rename fails
  (:func:`recover_old` deals with the ``.old`` folder of a run killed in between).

Docs: docs/cli/export.md.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.fileio import (
    check_folder_path,
    check_writable_dir,
    deferred_signals,
    folder_lock,
    temp_path,
)

__all__ = [
    "build_folder",
    "check_output",
    "error_where",
    "kept_note",
    "prepare_output",
    "publish",
    "recover_old",
]


def prepare_output(output: Path, overwrite: bool) -> None:
    """Refuse, in one line, an ``output`` that is a file, a mount point, or a non-empty
    folder (without ``overwrite``, or holding no LeRobot dataset to replace)."""
    if output.exists() and not output.is_dir():
        raise UserError(f"--output {output} is a file; give a folder")
    if os.path.ismount(output):  # the dataset is built next to it and renamed onto it
        raise UserError(f"--output {output} is a mount point; give a folder inside it")
    if output.is_dir() and any(output.iterdir()):
        if not overwrite:
            raise UserError(
                f"output folder {output} is not empty; choose another --output or pass "
                "--overwrite to replace the dataset in it"
            )
        if not (output / fmt.INFO_PATH).is_file():
            raise UserError(
                f"output folder {output} is not empty and holds no LeRobot dataset "
                f"(no {fmt.INFO_PATH}); refusing to delete it, choose another --output"
            )


def check_output(output: str | os.PathLike[str], overwrite: bool) -> Path:
    """Before any episode is read: ``output`` can become the dataset folder (not a file, a
    symlink loop or a link to a missing path; missing, empty or, with ``overwrite``, a
    dataset), and its parent, where the dataset is built and renamed onto ``output``, is a
    folder this process can write in (created if missing, as the export will). Returns
    ``output`` resolved."""
    check_folder_path(output, "--output")  # first: resolving a symlink loop raises
    output = Path(output).expanduser().resolve()
    prepare_output(output, overwrite)
    check_writable_dir(output.parent, "--output")
    return output


@contextmanager
def build_folder(output: Path) -> Iterator[Path]:
    """The hidden folder the dataset is built in, empty and locked for this export, and
    removed on the way out (error, Ctrl-C, SIGTERM). One a killed run left is reused after
    emptying it; one another export holds raises FolderBusyError."""
    tmp = temp_path(output)
    if tmp.is_symlink() or (tmp.exists() and not tmp.is_dir()):
        tmp.unlink()
    try:
        tmp.mkdir()
    except FileExistsError:  # a killed run's, or another export's: the lock tells
        pass
    with folder_lock(tmp):
        ours = _identity(tmp)
        try:
            for entry in list(tmp.iterdir()):  # a killed run's leftovers
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
            yield tmp
        finally:
            with deferred_signals():  # a second signal must not stop the cleanup
                if _identity(tmp) == ours:  # not yet published, nor another export's since
                    shutil.rmtree(tmp, ignore_errors=True)


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino


def recover_old(output: Path) -> None:
    """Deal with the ``.<name>.old`` folder of a run killed while replacing a dataset: put
    it back when ``output`` is missing (the old dataset is never lost), else remove it.
    Called holding the build folder's lock."""
    old = output.with_name(f".{output.name}.old")
    if not old.is_dir():
        return
    with deferred_signals():
        if output.exists():
            shutil.rmtree(old)
        else:
            os.replace(old, output)


def kept_note(output: Path, existing: bool, published: bool) -> str:
    """What an interrupted export kept, for the one line of ``run_cli``.

    Args:
        output: the dataset folder asked for.
        existing: whether a dataset was in ``output`` before the export.
        published: whether the finished dataset had already been moved onto ``output``.
    """
    if published:
        return f"the export had finished: the dataset is complete in {output}"
    if existing:
        return f"the partial dataset was removed; the dataset already in {output} is unchanged"
    return f"the partial dataset was removed; nothing was written to {output}"


def error_where(exc: OSError) -> str:
    """`` (<file>)`` naming the file of an OSError, or "" when it names none."""
    name = getattr(exc, "filename", None)
    return f" ({name})" if name else ""


def publish(tmp: Path, output: Path) -> None:
    """Move the finished dataset ``tmp`` onto ``output`` (empty, or a dataset to replace:
    it is moved aside first and put back if the move fails)."""
    if not output.exists():
        os.replace(tmp, output)
        return
    old = output.with_name(f".{output.name}.old")
    shutil.rmtree(old, ignore_errors=True)
    os.replace(output, old)
    try:
        os.replace(tmp, output)
    except BaseException:
        os.replace(old, output)
        raise
    shutil.rmtree(old, ignore_errors=True)
