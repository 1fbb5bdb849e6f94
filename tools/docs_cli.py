"""Flag tables of the command-line tools, generated from their argparse parsers.

The documentation build (``tools/docs_hooks.py``) replaces a marker line
``<!-- cli-flags: record -->`` on a page with the table of that subcommand's parser, so a
flag added to a script appears on its page without editing the page; ``tests/docs`` checks
every flag of every parser appears on the built page.

    python tools/docs_cli.py record      # print the Markdown table of trossen-mujoco record
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

from trossen_arm_mujoco.cli import SUBCOMMANDS

#: subcommand -> module whose ``build_parser()`` defines its flags (record's parser lives in
#: record_args so the flags are importable without the recording machinery)
PARSER_MODULES: dict[str, str] = {
    **SUBCOMMANDS,
    "record": "trossen_arm_mujoco.scripts.record_args",
}


def build_parser(command: str) -> argparse.ArgumentParser:
    """The parser of ``trossen-mujoco <command>``; an unknown command raises ``KeyError``
    naming the valid ones."""
    if command not in PARSER_MODULES:
        raise KeyError(f"unknown command {command!r}; valid: {', '.join(PARSER_MODULES)}")
    return importlib.import_module(PARSER_MODULES[command]).build_parser()


def documented_actions(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The parser's flags and positionals, without ``--help``."""
    return [a for a in parser._actions if not isinstance(a, argparse._HelpAction)]


def _portable(text: object) -> str:
    """``text`` with this machine's home folder written ``~`` (defaults under HOME)."""
    return str(text).replace(str(Path.home()), "~")


def _cell(text: object) -> str:
    """``text`` safe inside one Markdown table cell."""
    return _portable(text).replace("|", "\\|").replace("\n", " ").strip()


def _default(action: argparse.Action) -> str:
    """The default as the page shows it: empty for flags that only switch on."""
    if action.default is None or action.default == argparse.SUPPRESS:
        return ""
    if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction)):
        return ""
    shown = action.default if isinstance(action.default, str) else repr(action.default)
    return f"`{_cell(shown)}`"


def flags_markdown(command: str) -> str:
    """A Markdown section listing every flag of ``command``: its names, value, default and
    help (``%(default)s`` expanded as argparse would)."""
    parser = build_parser(command)
    formatter = parser._get_formatter()
    rows = ["| Flag | Value | Default | Meaning |", "|---|---|---|---|"]
    for action in documented_actions(parser):
        names = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.dest}`"
        if action.nargs == 0:
            value = ""
        elif action.choices is not None:
            value = " \\| ".join(f"`{c}`" for c in action.choices)
        else:
            value = f"`{action.metavar or action.dest.upper()}`"
            if action.nargs in ("+", "*"):
                value += " ..."
        help_text = formatter._expand_help(action) if action.help else ""
        rows.append(f"| {names} | {value} | {_default(action)} | {_cell(help_text)} |")
    usage = _portable(parser.format_usage().strip().replace("usage: ", "", 1))
    return "\n".join(
        [
            "## All flags",
            "",
            f"Generated from the parser (`{PARSER_MODULES[command]}.build_parser()`) when the "
            "site is built.",
            "",
            "```text",
            usage,
            "```",
            "",
            *rows,
            "",
        ]
    )


if __name__ == "__main__":
    print(flags_markdown(sys.argv[1] if len(sys.argv) > 1 else "record"))
