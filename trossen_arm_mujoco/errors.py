"""User-facing errors and the command-line wrapper that turns them into one-line messages."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Sequence

#: Exit status of a command-line entry point after a user error.
EXIT_USER_ERROR = 2
#: Exit status after Ctrl-C or SIGTERM (128 + SIGINT).
EXIT_INTERRUPTED = 130


class UserError(Exception):
    """A mistake the user can fix (bad flag, missing file, invalid data).

    Command-line entry points print the message on one line, without a traceback,
    and exit with status 2.
    """


def report_error(message: object, status: int = EXIT_USER_ERROR) -> int:
    """Print ``error: <message>`` to stderr as one line and return the exit status.

    A message spanning several lines is joined with "; ", so stderr holds exactly one
    line per error. Usage in a command's ``main``: ``return report_error(msg, 1)``.
    """
    text = str(message)
    if "\n" in text:
        text = "; ".join(line.strip() for line in text.splitlines() if line.strip())
    print(f"error: {text}", file=sys.stderr)
    return status


def unknown_name_error(kind: str, name: str, valid: Iterable[str], hint: str = "") -> UserError:
    """Build the standard error for an unknown name, listing the valid ones."""
    names = ", ".join(sorted(valid))
    msg = f"unknown {kind} '{name}'; valid {kind}s: {names}"
    if hint:
        msg += f" ({hint})"
    return UserError(msg)


def run_cli(
    main: Callable[[Sequence[str] | None], int | None], argv: Sequence[str] | None = None
) -> int:
    """Run a CLI ``main`` and map user errors to a one-line message and exit code 2.

    KeyboardInterrupt exits with 130 after the callee has cleaned up.
    """
    try:
        rc = main(argv)
    except UserError as exc:
        return report_error(exc)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return int(rc or 0)
