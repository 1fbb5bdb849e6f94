"""The fenced code blocks of the documentation pages, and which of them CI runs.

Every block on the site is one of:

- data or output (language ``text``, ``json``, ``yaml``, ``toml``): shown, not run;
- code (``python``, ``bash``): run by ``tests/docs/test_code_blocks.py``, each page's
  blocks in order in one fresh process, in an empty folder that is also ``HOME``;
- code that cannot run there, marked on its first line, which the page shows::

      # needs: hardware  (why: leader arms, a Ray cluster, ...)
      # needs: long-run  (why: installs, trains, records minutes of episodes, ...)

A block without a language fails the test, so nothing is left unclassified.

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
_NEEDS = re.compile(r"^# needs: ([\w-]+)\s+\((.+)\)\s*$")
_OPEN = re.compile(r"^(`{3,})\s*([\w+-]*)(.*)$")


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
    """The fenced blocks of one Markdown file, in order; a malformed ``# needs:`` line (an
    unknown kind, no reason) raises ``ValueError`` naming the page and line."""
    lines = path.read_text(encoding="utf-8").splitlines()
    page = path.relative_to(DOCS).as_posix() if path.is_relative_to(DOCS) else path.name
    found, i = [], 0
    while i < len(lines):
        match = _OPEN.match(lines[i])
        if not match:
            i += 1
            continue
        ticks, language = match.group(1), match.group(2)
        end = i + 1
        while end < len(lines) and not lines[end].startswith(ticks):
            end += 1
        body = lines[i + 1 : end]
        needs = reason = ""
        if body and body[0].startswith("# needs:"):
            mark = _NEEDS.match(body[0])
            if not mark or mark.group(1) not in NEEDS:
                raise ValueError(
                    f"{page}:{i + 2}: write '# needs: hardware  (why)' or "
                    f"'# needs: long-run  (why)', not {body[0]!r}"
                )
            needs, reason = mark.group(1), mark.group(2)
        found.append(Fence(page, i + 1, language, "\n".join(body) + "\n", needs, reason))
        i = end + 1
    return found


def site_pages() -> list[Path]:
    """Every Markdown page under docs/, sorted."""
    return sorted(DOCS.rglob("*.md"))


if __name__ == "__main__":
    for path in site_pages():
        for fence in fences(path):
            state = f"needs {fence.needs}" if fence.needs else ("run" if fence.runs else "shown")
            print(f"{fence.page}:{fence.line} {fence.language or '-'} {state}")
