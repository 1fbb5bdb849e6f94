"""Every table of measurements on the site names the benchmarks/ script that produced it,
when and where it ran (tools/docs_figures.py says what counts)."""

from __future__ import annotations

from pathlib import Path

import docs_figures
import pytest

PAGES = sorted(docs_figures.DOCS.rglob("*.md"))
#: Pages whose figure tables do not come from a benchmarks/ script yet, and why: each is an
#: expected failure, so the test says so as soon as the page is fixed.
UNSOURCED: dict[str, str] = {
    "testing.md": "the test suite's timings come from tools/run_tests.sh (it prints each leg's "
    "wall-clock time), not from a benchmarks/ script",
}


def _params():
    for page in PAGES:
        name = page.relative_to(docs_figures.DOCS).as_posix()
        if not docs_figures.figure_tables(page):
            continue
        marks = (
            [pytest.mark.xfail(strict=True, reason=UNSOURCED[name])] if name in UNSOURCED else []
        )
        yield pytest.param(page, id=name, marks=marks)


@pytest.mark.parametrize("page", list(_params()))
def test_figure_tables_say_which_benchmark_when_and_where(page: Path):
    problems = [
        f"{t.page}:{t.line} {t.header[:60]}: {', '.join(t.problems())}"
        for t in docs_figures.figure_tables(page)
        if t.problems()
    ]
    assert not problems, "\n".join(problems)


def test_the_benchmarks_page_has_figure_tables():
    tables = docs_figures.figure_tables(docs_figures.DOCS / "benchmarks.md")
    assert len(tables) >= 8
    assert "benchmarks/record_episode.py" in tables[0].scripts()


def test_an_unsourced_figure_table_is_found(tmp_path: Path):
    page = tmp_path / "page.md"
    page.write_text(
        "# Page\n\nOn the 2-core machine.\n\n## Speed\n\nFast, measured by hand.\n\n"
        "| env | wall (ms) |\n|---|---|\n| A | 3.1 |\n\n"
        "## Flags\n\n| flag | default | meaning |\n|---|---|---|\n| `--x` | 1 | x |\n\n"
        "```text\n| wall | CPU |\n|---|---|\n```\n"
    )
    [table] = docs_figures.figure_tables(page)  # not the flag table, not the fenced one
    assert table.line == 9
    assert table.problems() == ["no benchmarks/ script that exists", "no date (YYYY-MM-DD)"]
    page.write_text(
        "# Page\n\n## Speed\n\n`python benchmarks/record_episode.py` on 2026-11-26, idle 2-core "
        "CPU:\n\n| env | wall (ms) |\n|---|---|\n| A | 3.1 |\n\n"
        "`benchmarks/no_such_script.py`, 2026-11-26:\n\n| env | wall (ms) |\n|---|---|\n"
    )
    first, second = docs_figures.figure_tables(page)
    assert first.problems() == []
    assert second.problems() == ["no benchmarks/ script that exists"]
