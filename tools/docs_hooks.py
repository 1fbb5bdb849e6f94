"""MkDocs hooks of the documentation site (``mkdocs.yml`` ``hooks:``).

A page line ``<!-- cli-flags: <command> -->`` becomes the flag table of that
``trossen-mujoco`` subcommand, generated from its argparse parser (``tools/docs_cli.py``).
Each highlighted code block carries its text for the copy button (``data-copy``).
"""

from __future__ import annotations

import html
import re
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from docs_cli import PARSER_MODULES, flags_markdown  # noqa: E402

_MARKER = re.compile(r"^<!-- cli-flags: ([\w-]+) -->$", re.MULTILINE)
_BLOCK = re.compile(
    r'<div class="((?:[\w-]+ )*highlight)">(<pre\b.*?<code\b[^>]*>(.*?)</code>)', re.DOTALL
)  # pages' fences and mkdocstrings' signatures ("doc-signature highlight")


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


def on_page_content(content: str, page: Any, config: Any, files: Any) -> str:
    """Give each highlighted code block its text as ``data-copy``, which Material's copy
    button copies as is. Without it the button copies the block's rendered text
    (``innerText``), and the lines drawn as blocks of their own (a long line wraps with a
    hanging indent: ``docs/stylesheets/extra.css``) would come out with an empty line between
    each, breaking every ``\\`` continuation."""

    def carry(match: re.Match[str]) -> str:
        classes, block, code = match.groups()
        text = html.unescape(re.sub(r"<[^>]+>", "", code)).rstrip()
        return f'<div class="{classes}" data-copy="{html.escape(text)}">{block}'

    return _BLOCK.sub(carry, content)
