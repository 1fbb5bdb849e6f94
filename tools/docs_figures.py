"""The tables of measurements on the documentation pages, and what their sections say about
where the figures come from.

A *figure table* is a Markdown table whose header names a measurement (wall or CPU time, a
rate, a ratio, a success rate, a size, a latency...). Its *section* is the text from the last
heading of level 1 or 2 before it down to the table; its *lead-in* the part of that after the
previous figure table. Every figure table's lead-in must name a script under ``benchmarks/``
that exists, its section a date (``YYYY-MM-DD``), and its section or the page's opening
section where it ran (a machine: ``2-core``, ``H100``, ...): ``tests/docs/test_figures.py``
checks it on every page.

    python tools/docs_figures.py      # list every figure table: page:line script date where
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: Header words of a table of measurements (case-insensitive, whole words).
MEASURES = re.compile(
    r"\b(wall|CPU|ratio|steps/s|episodes/h|solves/s|frames/s|success|PSNR|KiB|MB|ms|Hz|"
    r"per (frame|step|episode)|write \(s\)|latency|throughput|file size|loss|wall time)\b",
    re.IGNORECASE,
)
SCRIPT = re.compile(r"benchmarks/[\w./-]+\.(?:py|sh)")
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")
WHERE = re.compile(r"\b(\d+-core|H100|H200|GPU|CPU machine|machine)\b", re.IGNORECASE)
_DELIMITER = re.compile(r"^\|(\s*:?-+:?\s*\|)+\s*$")


@dataclass(frozen=True)
class FigureTable:
    """A table of measurements: its page (relative to docs/), the line of its header
    (1-based), the header, the text of its section and of its lead-in before it, and the
    page's opening section (before the first level-2 heading)."""

    page: str
    line: int
    header: str
    section: str
    lead_in: str
    opening: str

    def scripts(self) -> list[str]:
        """The ``benchmarks/`` scripts its lead-in names that exist in the repository."""
        return sorted({s for s in SCRIPT.findall(self.lead_in) if (ROOT / s).is_file()})

    def problems(self) -> list[str]:
        """What its section fails to say (empty when it names a script, a date and a place)."""
        missing = []
        if not self.scripts():
            missing.append("no benchmarks/ script that exists")
        if not DATE.search(self.section):
            missing.append("no date (YYYY-MM-DD)")
        if not WHERE.search(self.section) and not WHERE.search(self.opening):
            missing.append("no machine (e.g. 'idle 2-core CPU', 'H100')")
        return missing


def figure_tables(path: Path) -> list[FigureTable]:
    """The figure tables of one Markdown page, in order (tables inside code fences are not
    tables)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    page = path.relative_to(DOCS).as_posix() if path.is_relative_to(DOCS) else path.name
    found: list[FigureTable] = []
    section_start, lead_start, opening_end, fence = 0, 0, None, ""
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        if stripped.startswith(("```", "~~~")):
            mark = stripped[:3]
            fence = "" if fence == mark else (fence or mark)
            continue
        if fence:
            continue
        if re.match(r"^#{1,2} ", line):
            section_start = lead_start = i
            if line.startswith("## ") and opening_end is None:
                opening_end = i
        is_header = line.startswith("|") and i + 1 < len(lines) and _DELIMITER.match(lines[i + 1])
        if is_header and MEASURES.search(line):
            opening = "\n".join(lines[: opening_end if opening_end is not None else i])
            section, lead_in = "\n".join(lines[section_start:i]), "\n".join(lines[lead_start:i])
            found.append(FigureTable(page, i + 1, line, section, lead_in, opening))
            lead_start = i + 1
    return found


if __name__ == "__main__":
    for path in sorted(DOCS.rglob("*.md")):
        for table in figure_tables(path):
            state = "; ".join(table.problems()) or ", ".join(table.scripts())
            print(f"{table.page}:{table.line} {table.header[:50]}  ->  {state}")
