"""The public API is explicit: every module of the package says what it exports (``__all__``),
every exported name resolves, and every exported module, class, function and public method
or property of an exported class has a docstring.

Modules are found on disk (every ``.py`` file under the package, namespace folders such as
``policies/`` included; a path part starting with ``_`` other than ``__init__.py`` is
private), so a new module is checked without being listed here.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import os
import types
from pathlib import Path

import pytest

import trossen_arm_mujoco

PACKAGE_DIR = Path(trossen_arm_mujoco.__file__).parent
PACKAGE = trossen_arm_mujoco.__name__


def public_modules() -> list[str]:
    """Dotted names of every public module of the package, sorted."""
    names = []
    for path in sorted(PACKAGE_DIR.rglob("*.py")):
        parts = path.relative_to(PACKAGE_DIR).with_suffix("").parts
        if any(p.startswith("_") and p != "__init__" for p in parts):
            continue
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names.append(".".join((PACKAGE, *parts)))
    return names


MODULES = public_modules()


def _import(name: str) -> types.ModuleType:
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:  # an optional extra that is not installed here
        if exc.name == "lerobot" and os.environ.get("TROSSEN_LEROBOT_PYTHON"):
            # this module is py312: the Python 3.12 leg checks it beside LeRobot
            pytest.skip("run by the Python 3.12 leg of tools/run_tests.sh (marker py312)")
        if exc.name and not exc.name.startswith(PACKAGE):
            pytest.skip(f"{name} needs {exc.name}")
        raise


def _own_doc(obj: object) -> str | None:
    """The docstring written for ``obj`` (a class: not the signature a dataclass or a
    NamedTuple makes up when it has none; a method or property: its own or inherited)."""
    doc = inspect.getdoc(obj)
    if inspect.isclass(obj):
        doc = obj.__dict__.get("__doc__")
        generated = f"{obj.__name__}("
        if (
            doc
            and doc.startswith(generated)
            and (dataclasses.is_dataclass(obj) or hasattr(obj, "_fields"))
        ):
            return None
    return doc.strip() if isinstance(doc, str) and doc.strip() else None


def _public_members(cls: type) -> list[str]:
    """Public methods and properties defined in ``cls`` itself."""
    out = []
    for name, attr in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(attr, (staticmethod, classmethod)):
            attr = attr.__func__
        if inspect.isfunction(attr) or isinstance(attr, property):
            out.append(name)
    return out


def undocumented(module: types.ModuleType) -> list[str]:
    """Public names of ``module`` (itself, its ``__all__``'s classes and functions defined
    there, their public methods and properties) without a docstring."""
    missing = [] if _own_doc(module) else [module.__name__]
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name, None)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue  # constants, type aliases, submodules
        if getattr(obj, "__module__", None) != module.__name__:
            continue  # re-exported: checked in the module that defines it
        if not _own_doc(obj):
            missing.append(f"{module.__name__}.{name}")
        if inspect.isclass(obj):
            for member in _public_members(obj):
                if not _own_doc(_member(obj, member)):
                    missing.append(f"{module.__name__}.{name}.{member}")
    return missing


def _member(cls: type, name: str) -> object:
    """A method or property of ``cls`` as ``inspect.getdoc`` follows it up the MRO."""
    attr = inspect.getattr_static(cls, name)
    if isinstance(attr, (staticmethod, classmethod)):
        return getattr(cls, name)
    if isinstance(attr, property):
        for base in cls.__mro__:
            prop = base.__dict__.get(name)
            if isinstance(prop, property) and prop.__doc__:
                return prop
        return attr
    return getattr(cls, name)


def test_every_module_is_found():
    """The walk sees the package's layers, namespace folders included."""
    for expected in (
        PACKAGE,
        f"{PACKAGE}.robot.robot_view",
        f"{PACKAGE}.tasks.sampler_settings",
        f"{PACKAGE}.policies.transfer_cube",
        f"{PACKAGE}.scripts.common_options",
        f"{PACKAGE}.twin.teleop",
    ):
        assert expected in MODULES
    assert not any(part.startswith("_") for m in MODULES for part in m.split(".")[1:])


@pytest.mark.parametrize("name", MODULES)
def test_module_declares_what_it_exports(name):
    module = _import(name)
    exported = getattr(module, "__all__", None)
    assert exported is not None, f"{name} has no __all__"
    assert isinstance(exported, (list, tuple)), f"{name}.__all__ must be a list"
    assert all(isinstance(n, str) for n in exported)
    assert len(set(exported)) == len(exported), f"{name}.__all__ lists a name twice"
    unresolved = [n for n in exported if not hasattr(module, n)]
    assert not unresolved, f"{name}.__all__ names what it does not define: {unresolved}"
    assert not [n for n in exported if n.startswith("_")], f"{name} exports a private name"


@pytest.mark.parametrize("name", MODULES)
def test_public_names_have_docstrings(name):
    missing = undocumented(_import(name))
    assert not missing, "no docstring: " + ", ".join(missing)


def test_the_check_catches_a_missing_docstring():
    """The checker itself fails on what it is meant to catch."""
    module = types.ModuleType("fake_public", "A module.")

    def documented() -> None:
        """Has one."""

    def bare() -> None:
        pass

    class Thing:
        """A thing."""

        def ok(self) -> None:
            """Fine."""

        def quiet(self) -> None:
            pass

        @property
        def size(self) -> int:
            return 1

    @dataclasses.dataclass
    class Record:
        value: int = 0

    for obj in (documented, bare, Thing, Record):
        obj.__module__ = "fake_public"
    module.__all__ = ["documented", "bare", "Thing", "Record"]
    module.documented, module.bare, module.Thing, module.Record = documented, bare, Thing, Record
    assert undocumented(module) == [
        "fake_public.bare",
        "fake_public.Thing.quiet",
        "fake_public.Thing.size",
        "fake_public.Record",
    ]
    module.__doc__ = None
    assert undocumented(module)[0] == "fake_public"
