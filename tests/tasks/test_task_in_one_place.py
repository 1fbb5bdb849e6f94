"""A task's facts live in its own module(s) and config: no other module names a shipped task.

What counts as naming one: a string constant in code (not a docstring) equal to a shipped
task's name or alias, or to one of its gym ids (a default such as ``task="sim_insertion"``, a
key of a per-task table). Prose that mentions a task (help texts, comments, docstrings) is
not counted. Allowed places: ``tasks/`` (the tasks and the registry), ``policies/`` (the
scripted policies) and ``config/`` (the YAML files).
"""

from __future__ import annotations

import ast
from pathlib import Path

from trossen_arm_mujoco.gym.registration import ENV_IDS
from trossen_arm_mujoco.tasks import registry

REPO = Path(__file__).resolve().parents[2]
ALLOWED = ("tasks", "policies", "config")
SHIPPED = [e for e in registry.ENTRIES if e.package == "trossen_arm_mujoco"]


def _docstrings(tree: ast.AST) -> set[int]:
    found = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            if isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
                found.add(id(body[0].value))
    return found


def _modules() -> list[Path]:
    package = REPO / "trossen_arm_mujoco"
    plugin = REPO / "plugins" / "lerobot_env_trossen" / "lerobot_env_trossen"
    return [
        p
        for p in [*package.rglob("*.py"), *plugin.rglob("*.py")]
        if not (p.is_relative_to(package) and p.relative_to(package).parts[0] in ALLOWED)
    ]


def test_no_module_outside_the_tasks_names_a_shipped_task():
    names = {x for e in SHIPPED for x in (e.name, *e.aliases, *e.gym_ids)}
    assert {"sim_transfer_cube", "transfer_cube", "reach"} <= names
    found = []
    for path in _modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = _docstrings(tree)
        found += [
            f"{path.relative_to(REPO)}:{node.lineno}: {node.value!r}"
            for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and id(node) not in docs and node.value in names
        ]
    assert not found, "name the task through tasks.registry instead: " + ", ".join(found)


def test_the_front_doors_derive_from_the_declarations():
    for entry in registry.ENTRIES:
        for env_id in entry.gym_ids:
            assert ENV_IDS[env_id][1] == entry.name
    assert set(ENV_IDS) == {i for e in registry.ENTRIES for i in e.gym_ids}
    from trossen_arm_mujoco.eval.scores import STAGES

    assert {n: dict(e.stages) for n, e in registry.TASKS.items() if e.stages} == dict(STAGES)
    assert registry.sim_task_configs() == {
        n: dict(e.record) for n, e in registry.TASKS.items() if e.policy
    }
