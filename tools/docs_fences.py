"""The fenced code blocks of the documentation pages, and which of them CI runs.

Every block on the site is one of:

- data or output (language ``text``, ``json``, ``yaml``, ``toml``): shown, not run;
- code (``python``, ``bash``): run by ``tests/docs/test_code_blocks.py``, each page's
  blocks in order in one fresh process, in an empty folder that is also ``HOME``;
- code that cannot run there, marked by an HTML comment on the line right before its opening
  fence, which neither the built site nor GitHub shows (readers copy the block as it is)::

      <!-- needs: hardware (why: leader arms, a Ray cluster, ...) -->
      <!-- needs: long-run (why: installs, trains, records minutes of episodes, ...) -->

A block without a language fails the test, so nothing is left unclassified; so does a mark
inside a block (the old ``# needs:`` first line, which readers saw) or one that no fence follows.

    python tools/docs_fences.py     # list every block: page:line language run|needs ...
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
CODE_LANGUAGES = ("python", "bash")
DATA_LANGUAGES = ("text", "json", "yaml", "toml")
NEEDS = ("hardware", "long-run")
_NEEDS = re.compile(r"^<!-- needs: ([\w-]+)\s+\((.+)\)\s*-->\s*$")
_MARK_START = "<!-- needs:"
_FORM = "<!-- needs: hardware (why) --> or <!-- needs: long-run (why) -->"
_OPEN = re.compile(r"^(\s*)(`{3,})\s*([\w+-]*)(.*)$")  # indented: in a list item


@dataclass(frozen=True)
class Fence:
    """One fenced block: its page (relative to docs/), the line of its opening fence
    (1-based), its language ("" when none), its text, and its ``needs`` mark
    ("" when it runs)."""

    page: str
    line: int
    language: str
    text: str
    needs: str = ""
    reason: str = ""

    @property
    def runs(self) -> bool:
        """Whether CI runs this block."""
        return self.language in CODE_LANGUAGES and not self.needs


def fences(path: Path) -> list[Fence]:
    """The fenced blocks of one Markdown file, in order. A malformed ``<!-- needs: -->`` mark (an
    unknown kind, no reason), one no fence follows, or a ``# needs:`` line inside a block (where
    readers would see it) raises ``ValueError`` naming the page and line."""
    lines = path.read_text(encoding="utf-8").splitlines()
    page = path.relative_to(DOCS).as_posix() if path.is_relative_to(DOCS) else path.name
    found, i = [], 0
    while i < len(lines):
        match = _OPEN.match(lines[i])
        if not match:
            if lines[i].lstrip().startswith(_MARK_START):
                _mark(lines, i, page)  # raises: a mark must sit right before a fence
            i += 1
            continue
        indent, ticks, language = len(match.group(1)), match.group(2), match.group(3)
        end = i + 1
        while end < len(lines) and not lines[end].lstrip().startswith(ticks):
            end += 1
        body = [line[indent:] for line in lines[i + 1 : end]]
        if body and body[0].startswith("# needs:"):
            raise ValueError(
                f"{page}:{i + 2}: move the mark out of the block, onto the line before its "
                f"fence, where readers do not see it: {_FORM}"
            )
        needs = reason = ""
        if i > 0 and lines[i - 1].lstrip().startswith(_MARK_START):
            needs, reason = _mark(lines, i - 1, page)
        found.append(Fence(page, i + 1, language, "\n".join(body) + "\n", needs, reason))
        i = end + 1
    return found


def _mark(lines: list[str], i: int, page: str) -> tuple[str, str]:
    """The kind and reason of the ``needs`` mark on line ``i`` (0-based), which must be
    well-formed and directly followed by an opening fence."""
    mark = _NEEDS.match(lines[i].strip())
    if not mark or mark.group(1) not in NEEDS:
        raise ValueError(f"{page}:{i + 1}: write {_FORM}, not {lines[i]!r}")
    if i + 1 >= len(lines) or not _OPEN.match(lines[i + 1]):
        raise ValueError(f"{page}:{i + 1}: a needs mark goes on the line right before a fence")
    return mark.group(1), mark.group(2)


def site_pages() -> list[Path]:
    """Every Markdown page under docs/, sorted."""
    return sorted(DOCS.rglob("*.md"))


if __name__ == "__main__":
    for path in site_pages():
        for fence in fences(path):
            state = f"needs {fence.needs}" if fence.needs else ("run" if fence.runs else "shown")
            print(f"{fence.page}:{fence.line} {fence.language or '-'} {state}")
