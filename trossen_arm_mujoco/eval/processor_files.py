"""A LeRobot checkpoint's saved processors (``policy_preprocessor.json``,
``policy_postprocessor.json``): reading them, writing them atomically, and putting one of this
project's steps in its place (``eval.controller_limits_step``, ``eval.camera_pose_step``).

Plain JSON: no LeRobot import, so a checkpoint is prepared where only the simulator runs.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.fileio import atomic_path

__all__ = ["POSTPROCESSOR_FILE", "PREPROCESSOR_FILE", "place_step", "read_json", "write_json"]

#: The saved postprocessor and preprocessor of a LeRobot checkpoint.
POSTPROCESSOR_FILE = "policy_postprocessor.json"
PREPROCESSOR_FILE = "policy_preprocessor.json"


def read_json(path: Path) -> Any:
    """The JSON in ``path`` (``OSError`` / ``ValueError`` as raised: callers word them)."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` to ``path`` as indented JSON, atomically (temp file, then rename)."""
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")


def place_step(steps: list[dict[str, Any]], name: str, step: dict[str, Any], *,
               after: str = "", before: str = "") -> bool:  # fmt: skip
    """Put ``step`` (a saved processor step, ``registry_name`` ``name``) in ``steps``: in
    place of the step of that name when there is one, else right after the step named
    ``after``, else right before the one named ``before``, else last. True when ``steps``
    changed (False: that very step was there already)."""
    for i, s in enumerate(steps):
        if s.get("registry_name") == name:
            if s == step:
                return False
            steps[i] = step
            return True
    names = [s.get("registry_name") for s in steps]
    at = len(steps)
    if after in names:
        at = names.index(after) + 1
    elif before in names:
        at = names.index(before)
    steps.insert(at, step)
    return True
