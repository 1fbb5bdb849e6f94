"""User-facing errors and the command-line wrapper that turns them into one-line messages.

:func:`run_cli` runs a command's ``main``: a :class:`UserError` becomes one ``error: ...``
line and exit status 2; Ctrl-C (SIGINT) and SIGTERM both unwind the command as a
``KeyboardInterrupt`` (SIGTERM as its subclass :class:`Terminated`, and so do SIGHUP and
the other signals that would end the process; handled by :mod:`trossen_arm_mujoco.stopping`),
so every cleanup written for Ctrl-C also runs for them, and end with one ``interrupted (...)``
line and exit status 130 or 143 (128 + the signal). A command says what an interruption kept
with :func:`interrupt_note`. Python warnings raised meanwhile print as one ``note: ...`` line
each (:func:`plain_warnings`, :func:`note`).

Docs: docs/reference/errors.md.
"""

from __future__ import annotations

import argparse
import errno
import os
import signal
import sys
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from trossen_arm_mujoco.stopping import (
    RAISE,
    TERMINATING_SIGNALS,
    StopSignals,
    Terminated,
    interrupt_signal,
    signal_name,
)

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "EXIT_USER_ERROR",
    "ArgumentParser",
    "Terminated",
    "UserError",
    "describe_os_error",
    "interrupt_note",
    "note",
    "os_error_hint",
    "plain_warnings",
    "report_error",
    "run_cli",
    "show_warning_as_note",
    "unknown_name_error",
]

#: Exit status of a command-line entry point after a user error.
EXIT_USER_ERROR = 2
#: Exit status after Ctrl-C (128 + SIGINT).
EXIT_INTERRUPTED = 128 + signal.SIGINT
#: Exit status after SIGTERM (128 + SIGTERM).
EXIT_TERMINATED = 128 + signal.SIGTERM


class UserError(Exception):
    """A mistake the user can fix (bad flag, missing file, invalid data).

    Command-line entry points print the message on one line, without a traceback,
    and exit with status 2.

    A library function called both from Python and from a command can say how to fix the
    mistake in both words: ``hint`` for Python callers (``"pass overwrite=True"``),
    ``cli_hint`` for the command-line user (``"pass --overwrite"``). ``str(exc)`` is
    ``"<message> (<hint>)"``; :func:`run_cli` prints :attr:`cli_message`,
    ``"<message> (<cli_hint>)"``. Both survive pickling (worker processes).

    Args:
        message: what is wrong (and, without ``hint``, what to do).
        hint: what a Python caller should do.
        cli_hint: what a command-line user should do instead (default: ``hint``).
    """

    def __init__(
        self, message: object = "", *, hint: str | None = None, cli_hint: str | None = None
    ) -> None:
        super().__init__(f"{message} ({hint})" if hint else message)
        self.what = str(message)
        self.hint = hint
        self.cli_hint = cli_hint

    @property
    def cli_message(self) -> str:
        """The message for a command-line user: the ``cli_hint`` in place of the ``hint``."""
        if getattr(self, "cli_hint", None) is None:
            return str(self)
        return f"{self.what} ({self.cli_hint})"


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose flag mistakes are a ``UserError`` (one ``error:``
    line and exit 2 through ``run_cli``) instead of usage text plus an error line."""

    def error(self, message: str):  # type: ignore[override]
        raise UserError(f"{message} (see '{self.prog} --help')")


def report_error(message: object, status: int = EXIT_USER_ERROR) -> int:
    """Print ``error: <message>`` to stderr as one line and return the exit status.

    A message spanning several lines is joined with "; ", so stderr holds exactly one
    line per error. Usage in a command's ``main``: ``return report_error(msg, 1)``.
    """
    print(f"error: {_one_line(message)}", file=sys.stderr)
    return status


def note(message: object) -> None:
    """Print ``note: <message>`` to stderr as one line (several lines joined with "; "):
    something the user should know that is neither an error nor a reason to stop."""
    print(f"note: {_one_line(message)}", file=sys.stderr, flush=True)


def show_warning_as_note(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """A ``warnings.showwarning``: one ``note: <message>`` line on stderr, no source line.

    :func:`plain_warnings` installs it while a command runs; a worker process a command
    starts (spawned, so without it) can set ``warnings.showwarning`` to it too.

    Args:
        message: the warning.
        category: its class (not shown).
        filename: where it was raised (not shown).
        lineno: its line (not shown).
        file: the stream (default stderr).
        line: the source line (not shown).
    """
    text = _one_line(message)
    if category is not UserWarning and not text.startswith(category.__name__):
        text = f"{text} ({category.__name__})"
    try:
        print(f"note: {text}", file=sys.stderr if file is None else file, flush=True)
    except (OSError, ValueError):  # stderr closed: a warning must never end the command
        pass


@contextmanager
def plain_warnings() -> Iterator[None]:
    """Show the Python warnings (``warnings.warn``, the package's and the libraries') raised
    in the block as one plain ``note: <message>`` line each on stderr, without the file and
    source line Python prints; :func:`run_cli` does this for every command. The filters
    (which warnings are shown, and how often) are unchanged."""
    previous = warnings.showwarning
    warnings.showwarning = show_warning_as_note
    try:
        yield
    finally:
        if warnings.showwarning is show_warning_as_note:
            warnings.showwarning = previous


def _one_line(message: object) -> str:
    text = str(message)
    if "\n" in text:
        text = "; ".join(line.strip() for line in text.splitlines() if line.strip())
    return text


def unknown_name_error(kind: str, name: str, valid: Iterable[str], hint: str = "") -> UserError:
    """Build the standard error for an unknown name, listing the valid ones.

    Args:
        kind: what the name is (e.g. ``"task"``).
        name: the name given.
        valid: the valid names.
        hint: a sentence appended to the message.
    """
    names = ", ".join(sorted(valid))
    msg = f"unknown {kind} '{name}'; valid {kind}s: {names}"
    if hint:
        msg += f" ({hint})"
    return UserError(msg)


def describe_os_error(exc: BaseException) -> str:
    """The cause of a failed file operation in a few words: ``No space left on device
    (ENOSPC)``; the exception's own text when it has no errno."""
    number = getattr(exc, "errno", None)
    if isinstance(number, int) and number:
        return f"{os.strerror(number)} ({errno.errorcode.get(number, number)})"
    return " ".join(str(exc).split()) or type(exc).__name__


def os_error_hint(exc: BaseException, flag: str) -> str:
    """What to do about a failed write, naming the flag that chose the place (``--output``)."""
    number = getattr(exc, "errno", None)
    if number in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return f"free some disk space or choose another {flag}"
    if number == errno.EROFS:
        return f"the file system is read-only; choose another {flag}"
    if number in (errno.EACCES, errno.EPERM):
        return f"check the folder's permissions (and immutable attribute) or choose another {flag}"
    if number in (errno.ENOTDIR, errno.EEXIST):
        return f"a file is in the way; choose another {flag}"
    if number in (errno.EBUSY, errno.EXDEV):
        return f"{flag} is a mount point or on another file system; give a folder inside it"
    return f"check the folder or choose another {flag}"


@contextmanager
def interrupt_note(describe: Callable[[], str]) -> Iterator[None]:
    """Say what a Ctrl-C or SIGTERM inside the block kept: ``describe()`` is called when the
    interrupt passes through, and :func:`run_cli` prints it after ``interrupted (...):``.

    The innermost note wins (it knows the most).
    """
    try:
        yield
    except KeyboardInterrupt as exc:
        if getattr(exc, "kept", None) is None:
            try:
                exc.kept = describe()
            except Exception:  # a note must never replace the interrupt
                pass
        raise


def _interrupt_line(exc: KeyboardInterrupt, signum: int) -> str:
    name = "Ctrl-C" if signum == signal.SIGINT else signal_name(signum)
    kept = getattr(exc, "kept", None)
    return f"interrupted ({name}): {_one_line(kept)}" if kept else f"interrupted ({name})"


def run_cli(
    main: Callable[[Sequence[str] | None], int | None], argv: Sequence[str] | None = None
) -> int:
    """Run a CLI ``main`` and map user errors to a one-line message and exit code 2.

    For the duration of ``main``, SIGINT and SIGTERM raise (``KeyboardInterrupt``,
    :class:`Terminated`) in the main thread, and so do the other signals that would end the
    process (:data:`~trossen_arm_mujoco.stopping.TERMINATING_SIGNALS`) where no handler is
    installed (a ``StopSignals`` in mode ``RAISE``); a handler ``main`` installs itself
    replaces that one, and the previous handlers are restored afterwards. An interrupt that
    reaches here, after the callee has cleaned up, prints one line (with the callee's
    :func:`interrupt_note`) and exits with 130 after Ctrl-C, 143 after SIGTERM (128 + the
    signal's number).
    """
    stops = StopSignals(RAISE, (signal.SIGINT, *TERMINATING_SIGNALS)).install(
        over=(signal.SIGTERM,)
    )
    try:
        try:
            with plain_warnings():
                rc = main(argv)
        except UserError as exc:
            message = exc.cli_message
            stops.restore()
            return report_error(message)
        return int(rc or 0)
    except KeyboardInterrupt as exc:
        stops.restore()
        signum = interrupt_signal(exc, stops)
        print(_interrupt_line(exc, signum), file=sys.stderr)
        return 128 + int(signum)
    finally:
        stops.restore()
