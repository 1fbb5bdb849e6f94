"""The quick subset (``python -m pytest -m quick``, docs/testing.md) cannot silently rot: its
units are the package's subpackages and top-level modules, every entry of
``tests/conftest.py``'s ``QUICK`` exists and touches its unit, and what it names is marked."""

from __future__ import annotations

import ast
import re
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = "trossen_arm_mujoco"
PACKAGE_DIR = REPO / PACKAGE
TOP_LEVEL = "(top level)"


def _conftest(config: pytest.Config) -> ModuleType:
    """The suite's root conftest module, as pytest loaded it."""
    path = REPO / "tests" / "conftest.py"
    for plugin in config.pluginmanager.get_plugins():
        file = getattr(plugin, "__file__", None)
        if file and Path(file).resolve() == path:
            return plugin
    raise AssertionError("tests/conftest.py is not loaded")


@pytest.fixture(scope="module")
def quick(request) -> dict[str, tuple[str, ...]]:
    return _conftest(request.config).QUICK


def subpackages() -> set[str]:
    """Folders of the package that hold Python modules (namespace folders included)."""
    return {p.name for p in PACKAGE_DIR.iterdir() if p.is_dir() and any(p.rglob("*.py"))}


def top_level_modules() -> set[str]:
    """The package's own modules (not ``__init__``)."""
    return {p.stem for p in PACKAGE_DIR.glob("*.py") if p.stem != "__init__"}


def named_units(source: str) -> set[str]:
    """Subpackages and top-level modules a test module names: imported (any form), or
    written as ``trossen_arm_mujoco.x`` / ``trossen_arm_mujoco/x`` (``-m`` commands, paths)."""
    found = set(re.findall(rf"{PACKAGE}[./](\w+)", source))
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module == PACKAGE:
            found |= {a.name for a in node.names}
    return found


def test_the_units_are_the_packages(quick):
    """A new subpackage needs its entry in QUICK; a removed one loses it."""
    assert set(quick) == subpackages() | {TOP_LEVEL}
    assert all(quick.values()), "a unit without a quick test"


def test_every_entry_exists(quick):
    """Each module is a file of tests/; each single test is a test function of its module."""
    for unit, entries in quick.items():
        for entry in entries:
            module, _, name = entry.partition("::")
            path = REPO / module
            assert path.is_file() and module.startswith("tests/"), f"{unit}: {entry}"
            if name:
                tree = ast.parse(path.read_text(encoding="utf-8"))
                functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
                assert name in functions, f"{unit}: {module} has no test {name}"


def test_each_unit_is_touched(quick):
    """One of a subpackage's quick modules names it; the top-level ones name every
    top-level module between them."""
    named: dict[str, set[str]] = {}
    for unit, entries in quick.items():
        for entry in entries:
            source = (REPO / entry.partition("::")[0]).read_text(encoding="utf-8")
            named.setdefault(unit, set()).update(named_units(source))
    untouched = [unit for unit in quick if unit != TOP_LEVEL and unit not in named[unit]]
    assert not untouched, f"subpackages none of whose quick tests names them: {untouched}"
    missing = top_level_modules() - named[TOP_LEVEL]
    assert not missing, f"top-level modules no quick test names: {sorted(missing)}"


def test_no_serial_or_long_module_is_quick(request, quick):
    """A serial module skips in a run spread over the cores, so it cannot be the quick
    subset's only test of anything."""
    serial = set(_conftest(request.config).SERIAL_MODULES)
    for entries in quick.values():
        for entry in entries:
            assert entry.partition("::")[0] not in serial, f"{entry} is serial"


def test_what_quick_names_is_marked(request, quick):
    """Of the tests this session collected, those QUICK names carry the marker, and each
    entry whose module was collected matched at least one test."""
    conftest = _conftest(request.config)
    seen: dict[str, int] = {}
    for item in request.session.items:
        try:
            module = Path(item.path).resolve().relative_to(REPO).as_posix()
        except ValueError:
            continue
        name = getattr(item, "originalname", item.name)
        entry = f"{module}::{name}" if (module, name) in conftest.QUICK_TESTS else module
        quick_here = conftest._is_quick(module, name)
        assert quick_here == (item.get_closest_marker("quick") is not None), item.nodeid
        if quick_here:
            seen[entry] = seen.get(entry, 0) + 1
    if request.config.getoption("keyword"):
        return  # -k may leave out an entry's tests and keep others of its module
    collected = {Path(i.path).resolve() for i in request.session.items}
    for entries in quick.values():
        for entry in entries:
            if (REPO / entry.partition("::")[0]).resolve() in collected:
                assert seen.get(entry), f"{entry} matched no collected test"
