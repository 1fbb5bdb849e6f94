"""Documentation tests: the built site (``site/``, from ``mkdocs build --strict``) and the
pages' code blocks.

Without a built site the site tests skip, saying how to build it; ``tools/run_tests.sh``
builds it and sets ``TROSSEN_DOCS_REQUIRED=1``, which turns that skip into a failure.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SITE = REPO / "site"
sys.path.insert(0, str(REPO / "tools"))  # docs_cli, docs_fences, docs_gym


@pytest.fixture(scope="session")
def site() -> Path:
    """The built site folder; skips (or, with TROSSEN_DOCS_REQUIRED=1, fails) when absent."""
    if not (SITE / "index.html").is_file():
        message = (
            "the documentation site is not built: pip install -e '.[docs]' && mkdocs build --strict"
        )
        if os.environ.get("TROSSEN_DOCS_REQUIRED") == "1":
            pytest.fail(message)
        pytest.skip(message)
    return SITE
