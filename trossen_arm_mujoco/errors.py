"""User-facing errors and the command-line wrapper that turns them into one-line messages."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Sequence


class UserError(Exception):
    """A mistake the user can fix (bad flag, missing file, invalid data).

    Command-line entry points print the message on one line, without a traceback,
    and exit with status 2.
    """


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
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return int(rc or 0)
