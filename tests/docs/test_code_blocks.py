"""Every code block of the site runs in CI, or is marked as needing hardware or a long run."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import docs_fences
import pytest

PAGES = docs_fences.site_pages()
RUN_PAGES = [p for p in PAGES if any(f.runs for f in docs_fences.fences(p))]


def test_every_block_is_code_that_runs_data_or_marked():
    unknown = [
        f"{f.page}:{f.line} ({f.language or 'no language'})"
        for page in PAGES
        for f in docs_fences.fences(page)
        if f.language not in docs_fences.CODE_LANGUAGES + docs_fences.DATA_LANGUAGES
    ]
    assert not unknown, f"blocks without a known language: {unknown}"
    counts = {"runs": 0, "needs": 0}
    for page in PAGES:
        for f in docs_fences.fences(page):
            if f.language in docs_fences.CODE_LANGUAGES:
                counts["runs" if f.runs else "needs"] += 1
    assert counts["runs"] >= 10, counts  # the tutorial, the gym pages, the concepts


def test_every_cli_page_has_a_worked_example_that_runs():
    cli_pages = [p for p in PAGES if p.parent.name == "cli" and p.name != "index.md"]
    assert len(cli_pages) == 9
    without = [p.name for p in cli_pages if not any(f.runs for f in docs_fences.fences(p))]
    assert not without, f"CLI pages without a block CI runs: {without}"


def test_blocks_that_run_reach_loopback_only():
    """An address outside 127.0.0.0/8 (a real arm's) only ever appears in blocks marked
    ``<!-- needs: hardware (...) -->``, which never run."""
    address = re.compile(r"(?<![\d.])(\d{1,3})\.\d{1,3}\.\d{1,3}\.\d{1,3}(?![\d.])")
    outside = [
        f"{f.page}:{f.line}: {m.group(0)}"
        for page in PAGES
        for f in docs_fences.fences(page)
        if f.language in docs_fences.CODE_LANGUAGES and f.needs != "hardware"
        for m in address.finditer(f.text)
        if m.group(1) != "127"
    ]
    assert not outside, f"non-loopback addresses in blocks not marked hardware: {outside}"


def test_a_malformed_needs_mark_is_refused(tmp_path: Path):
    page = tmp_path / "page.md"
    page.write_text("<!-- needs: a gpu -->\n```bash\nls\n```\n")
    with pytest.raises(ValueError, match="page.md:1: write <!-- needs: hardware"):
        docs_fences.fences(page)
    page.write_text("<!-- needs: hardware (leader arms) -->\n\n```bash\nls\n```\n")
    with pytest.raises(ValueError, match="page.md:1: a needs mark goes on the line right before"):
        docs_fences.fences(page)
    page.write_text("```bash\n# needs: hardware  (leader arms)\nls\n```\n")  # readers saw it
    with pytest.raises(ValueError, match="page.md:2: move the mark out of the block"):
        docs_fences.fences(page)
    page.write_text("text\n<!-- needs: hardware (leader arms) -->\n```bash\nls\n```\n")
    [fence] = docs_fences.fences(page)
    assert (fence.needs, fence.reason, fence.runs, fence.text) == (
        "hardware",
        "leader arms",
        False,
        "ls\n",
    )
    page.write_text(
        "- a list item:\n\n  <!-- needs: long-run (minutes) -->\n  ```bash\n  ls\n  ```\n"
    )
    [fence] = docs_fences.fences(page)
    assert (fence.needs, fence.text) == ("long-run", "ls\n")


@pytest.mark.parametrize(
    "page", RUN_PAGES, ids=[p.relative_to(docs_fences.DOCS).as_posix() for p in RUN_PAGES]
)
def test_page_code_runs(page: Path, tmp_path: Path):
    """The page's runnable blocks, in order, in one fresh process (python) or shell (bash),
    in an empty folder that is also HOME (nothing written outside it)."""
    runnable = [f for f in docs_fences.fences(page) if f.runs]
    env = {**os.environ, "HOME": str(tmp_path), "MUJOCO_GL": "egl", "PYTHONUNBUFFERED": "1"}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    start = time.monotonic()
    python = "\n".join(f.text for f in runnable if f.language == "python")
    if python:
        script = tmp_path / "page_blocks.py"
        script.write_text(python)
        proc = subprocess.run(
            [sys.executable, str(script)],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=180,
        )
        assert proc.returncode == 0, f"{page}:\n{proc.stdout}\n{proc.stderr}"
    for fence in (f for f in runnable if f.language == "bash"):
        proc = subprocess.run(
            ["bash", "-euo", "pipefail", "-c", fence.text],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=180,
        )
        assert proc.returncode == 0, f"{fence.page}:{fence.line}:\n{proc.stdout}\n{proc.stderr}"
    assert time.monotonic() - start < 120, "keep the site's runnable blocks small"


def test_marks_are_hidden_on_the_built_pages(site: Path):
    """The needs marks are HTML comments: no built page shows one (the highlighter splits a
    code comment into spans, so the check reads the text with the tags removed)."""
    marked = [p for p in PAGES if any(f.needs for f in docs_fences.fences(p))]
    assert len(marked) >= 10
    for page in marked:
        built = site / page.relative_to(docs_fences.DOCS).with_suffix(".html")
        html = re.sub(r"<!--.*?-->", "", built.read_text(encoding="utf-8"), flags=re.DOTALL)
        text = re.sub(r"<[^>]+>", "", html)
        assert "needs: hardware" not in text and "needs: long-run" not in text, built
    teleop = (site / "cli" / "teleop.html").read_text(encoding="utf-8")
    assert "<!-- needs: hardware (leader arms" in teleop  # the mark is there, as a comment
