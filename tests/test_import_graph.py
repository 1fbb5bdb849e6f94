"""The package's module import graph, read statically: no cycles, no arrows up the layers.

What counts as an import of a package module ("an arrow" from the importing module):
``import trossen_arm_mujoco.x.y`` and ``from trossen_arm_mujoco.x import y`` (or their
relative forms) anywhere in a module: at module level, inside functions and methods (they run
when called, so they can close a cycle at run time just as well), and under
``if TYPE_CHECKING:``. Type-only imports never run, so they cannot fail an import; they count
anyway, for cycles as for layers: a module whose annotations name another depends on it for
its meaning (it cannot be read, moved or split without it), and an annotation naming an upper
layer is an arrow up like any other. The one exception is the package's own bootstrap,
``trossen_arm_mujoco/__init__.py`` (see ``LAYERS``).

``from pkg import name`` points at the submodule ``pkg.name`` when there is one, else at
``pkg`` (its ``__init__.py``). Importing a submodule also runs its parents' ``__init__.py``;
those implicit arrows are left out (every package's ``__init__`` imports its own submodules,
so they would make every package a cycle). Import paths held as strings and resolved with
``importlib`` at run time (the task registry's ``"module:Class"`` entries, gymnasium entry
points, optional extras) are not imports and are not counted.

Layers are those of the design page, docs/concepts/architecture.md (the flow of data:
imports point down the flow, never back up), listed in ``LAYERS`` lowest first. A module may
import modules of its own unit (the same subpackage, or itself for a top-level module) and of
units in lower layers; units sharing a layer may not import each other. A unit that is in no
layer fails the test: a new subpackage or top-level module is placed in ``LAYERS`` on purpose.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

PACKAGE = "trossen_arm_mujoco"
PACKAGE_DIR = Path(__file__).resolve().parent.parent / PACKAGE

#: Units (subpackages and top-level modules, by their name under the package), lowest first.
LAYERS: tuple[tuple[str, ...], ...] = (
    # helpers that know nothing of robots, worlds or tasks: stop signals, then the errors
    # and the command-line wrapper built on them
    ("stopping",),
    ("errors",),
    ("names", "clip", "fileio", "quaternion", "assets", "viewer", "processes"),
    # the one pool of local worker processes (record's and eval's; on processes)
    ("worker_pool",),
    ("images",),
    # what a robot is: move groups -> robot view -> robot (+ controllers, kinematics, layouts)
    ("robot",),
    # what the world is; the episode file format (on the robot's data layouts); the real arm's
    # driver, validation and replay (on the same layouts): none of them needs the others
    ("sim", "data", "real"),
    # what an episode is: task, sampler, registry, configs
    ("tasks",),
    # scripted policies (they read task geometry); the gymnasium front door
    ("policies", "gym"),
    # front doors built on the above: collection -> data files; LeRobot export
    ("collect", "export"),
    # what a policy is trained on, beyond the export: a pose encoder and its derived dataset
    ("train",),
    # front doors that reuse collection's episodes and seeds: a policy over seeds (also
    # export's layout); the kit served over the arm protocol and teleop (the served twin)
    ("eval", "twin"),
    # the package's bootstrap: sets MUJOCO_GL and registers the gymnasium ids (imports gym)
    ("__init__",),
    # the documented public surface: thin modules configuring the layers below
    ("constants",),
    ("utils",),
    ("demo",),
    ("ee_sim_env", "sim_env", "scripted_policy"),
    # the vendor's current Python API (src.controller: Controller, RobotType) over the robot layer
    ("src",),
    # command lines
    ("scripts",),
    ("cli",),
)

RANK: dict[str, int] = {unit: i for i, layer in enumerate(LAYERS) for unit in layer}


@dataclass(frozen=True)
class Arrow:
    """One import of a package module: ``source`` imports ``target`` at ``where``."""

    source: str  # dotted module name
    target: str
    where: str  # "path:line"
    type_only: bool


def package_modules(root: Path = PACKAGE_DIR) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file of the package."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of ``tree``, with whether it sits under ``if TYPE_CHECKING``."""

    def walk(node: ast.AST, type_only: bool) -> Iterator[tuple[ast.AST, bool]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, type_only
            elif isinstance(child, ast.If) and _is_type_checking(child.test):
                for sub in child.body:
                    yield from walk(ast.Module(body=[sub], type_ignores=[]), True)
                for sub in child.orelse:
                    yield from walk(ast.Module(body=[sub], type_ignores=[]), type_only)
            else:
                yield from walk(child, type_only)

    yield from walk(tree, False)  # type: ignore[misc]


def arrows(modules: dict[str, Path], root: Path = PACKAGE_DIR) -> list[Arrow]:
    """Every import of a package module by a package module (self-imports left out);
    ``modules`` from ``package_modules(root)``."""

    def resolve(name: str) -> str | None:  # the module itself, or its nearest package
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    found = []
    for source, path in modules.items():
        is_package = path.name == "__init__.py"
        for node, type_only in _imports(ast.parse(path.read_text(), str(path))):
            targets: list[str | None] = []
            if isinstance(node, ast.Import):
                targets = [resolve(a.name) for a in node.names if _ours(a.name)]
            else:
                base = node.module or ""
                if node.level:  # relative: from the importing module's package
                    here = source.split(".") if is_package else source.split(".")[:-1]
                    here = here[: len(here) - (node.level - 1)]
                    base = ".".join([*here, *([node.module] if node.module else [])])
                if _ours(base):
                    for alias in node.names:
                        sub = f"{base}.{alias.name}"
                        targets.append(sub if sub in modules else resolve(base))
            where = f"{path.relative_to(root.parent)}:{node.lineno}"
            found += [Arrow(source, t, where, type_only) for t in targets if t and t != source]
    return found


def _ours(name: str) -> bool:
    return name == PACKAGE or name.startswith(PACKAGE + ".")


def unit(module: str) -> str:
    """The layering unit of a module: its subpackage, its own name, or "__init__" (root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    nodes = sorted(set(edges) | {t for ts in edges.values() for t in ts})
    for start in nodes:
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def layer_violations(found: list[Arrow]) -> list[str]:
    """One line per arrow that points up the layers or sideways within a layer."""
    bad = []
    for a in found:
        src, dst = unit(a.source), unit(a.target)
        if src == dst:
            continue
        kind = " (type-only)" if a.type_only else ""
        if src not in RANK or dst not in RANK:
            missing = src if src not in RANK else dst
            bad.append(f"{a.where}: unit '{missing}' is in no layer: add it to LAYERS")
        elif RANK[dst] >= RANK[src]:
            way = "up" if RANK[dst] > RANK[src] else "sideways"
            bad.append(f"{a.where}: {a.source} -> {a.target}{kind} points {way} ({src} -> {dst})")
    return bad


def _edges(found: list[Arrow]) -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {}
    for a in found:
        edges.setdefault(a.source, set()).add(a.target)
    return edges


@pytest.fixture(scope="module")
def graph() -> list[Arrow]:
    return arrows(package_modules())


def test_the_graph_is_read(graph):
    """Sanity: the reader sees module-level, function-level and type-only imports."""
    pairs = {(a.source, a.target) for a in graph}
    assert (f"{PACKAGE}.robot.robot", f"{PACKAGE}.robot.robot_view") in pairs
    assert any(a.type_only for a in graph)
    assert len(graph) > 300


def test_no_import_cycles(graph):
    found = cycles(_edges(graph))
    assert not found, "import cycles (each line: the modules of one cycle):\n" + "\n".join(
        " <-> ".join(c) for c in found
    )


def test_imports_point_down_the_layers(graph):
    bad = layer_violations(graph)
    assert not bad, "imports against the layers of docs/concepts/architecture.md:\n" + "\n".join(
        bad
    )


def test_no_module_getattr_shims():
    """No module answers for names it does not define (``def __getattr__`` at module level:
    old import paths kept alive); an importer imports from the module that owns the name."""
    shims = [
        f"{path.relative_to(PACKAGE_DIR.parent)}:{node.lineno}"
        for path in package_modules().values()
        for node in ast.parse(path.read_text()).body
        if isinstance(node, ast.FunctionDef) and node.name in ("__getattr__", "__dir__")
    ]
    assert not shims, "module-level __getattr__ / __dir__: " + ", ".join(shims)


# -- the checks themselves can fail --------------------------------------------------------------
def test_a_cycle_and_an_arrow_up_are_caught(tmp_path):
    """A package with a function-level back import (the old ``move_group.__getattr__``
    shape) and a type-only arrow from robot/ up to tasks/ fails both checks."""
    pkg = tmp_path / PACKAGE
    (pkg / "robot").mkdir(parents=True)
    (pkg / "tasks").mkdir()
    for init in (pkg, pkg / "robot", pkg / "tasks"):
        (init / "__init__.py").write_text("")
    (pkg / "robot" / "move_group.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        f"    from {PACKAGE}.tasks.task import Task\n"
        "def __getattr__(name):\n"
        f"    from {PACKAGE}.robot.gripper_group import GripperGroup\n"
        "    return GripperGroup\n"
    )
    (pkg / "robot" / "gripper_group.py").write_text(
        f"from {PACKAGE}.robot.move_group import MoveGroup\n"
    )
    (pkg / "tasks" / "task.py").write_text("")
    (pkg / "tasks" / "sampler.py").write_text("from ..robot import move_group\n")  # relative
    found = arrows(package_modules(pkg), pkg)
    assert cycles(_edges(found)) == [
        [f"{PACKAGE}.robot.gripper_group", f"{PACKAGE}.robot.move_group"]
    ]
    (bad,) = layer_violations(found)
    assert "robot.move_group -> trossen_arm_mujoco.tasks.task (type-only) points up" in bad
    assert (f"{PACKAGE}.tasks.sampler", f"{PACKAGE}.robot.move_group") in {
        (a.source, a.target) for a in found
    }
