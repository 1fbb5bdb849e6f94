"""MkDocs hooks of the documentation site (``mkdocs.yml`` ``hooks:``).

A page line ``<!-- cli-flags: <command> -->`` becomes the flag table of that
``trossen-mujoco`` subcommand, generated from its argparse parser (``tools/docs_cli.py``).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from docs_cli import PARSER_MODULES, flags_markdown  # noqa: E402

_MARKER = re.compile(r"^<!-- cli-flags: ([\w-]+) -->$", re.MULTILINE)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Replace each ``cli-flags`` marker with the flag table of its command; an unknown
    command fails the build naming the valid ones."""

    def table(match: re.Match[str]) -> str:
        command = match.group(1)
        if command not in PARSER_MODULES:
            raise ValueError(
                f"{page.file.src_path}: unknown command {command!r} in a cli-flags marker; "
                f"valid: {', '.join(PARSER_MODULES)}"
            )
        return flags_markdown(command)

    return _MARKER.sub(table, markdown)
