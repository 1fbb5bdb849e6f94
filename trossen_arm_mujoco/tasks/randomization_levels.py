"""Named evaluation levels of scene variation: ``nominal``, ``train`` and a held-out ``hard``.

``nominal``: no randomization; ``train``: the task's own ``randomization`` section, what
``record --randomize`` trains on; ``hard``: the same kinds, each range widened past anything
``train`` draws (:func:`harder`: cameras moved 3x as much, lights tilted further, twice the
colour jitter, wider friction and mass, twice the damping and start noise; no distractors).
``eval --randomize LEVEL``, ``serve --randomize LEVEL`` and the env plugin's
``--env.randomize=LEVEL`` take them; a ``--randomization FILE`` replaces the task's section
first, and ``hard`` widens that.

Docs: docs/concepts/randomization.md, docs/train-eval.md.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from trossen_arm_mujoco.errors import UserError, unknown_name_error

__all__ = ["LEVELS", "harder", "level_section"]

#: The evaluation levels, easiest first.
LEVELS: tuple[str, ...] = ("nominal", "train", "hard")


def _widen(span: list[float], factor: float, centre: float, low: float = 0.0) -> list[float]:
    """``span`` ([lo, hi]) stretched by ``factor`` about ``centre`` (not below ``low``)."""
    lo, hi = float(span[0]), float(span[1])
    return [max(low, centre - (centre - lo) * factor), centre + (hi - centre) * factor]


def harder(section: Mapping[str, Any]) -> dict[str, Any]:
    """The ``hard`` level of a complete randomization ``section`` (every kind present, as
    ``tasks.randomization_schema.check_randomization`` returns it): each range widened as
    the module doc says, within the schema's bounds; ``enabled`` and names unchanged."""
    s = copy.deepcopy(dict(section))
    lights = s["lights"]
    lights["direction_deg"] = min(90.0, max(35.0, 2.5 * float(lights["direction_deg"])))
    lights["diffuse_scale"] = _widen(lights["diffuse_scale"], 1.75, 1.0)
    lights["specular_scale"] = _widen(lights["specular_scale"], 1.5, 1.0)
    lights["ambient"] = [float(lights["ambient"][0]), min(1.0, 2 * float(lights["ambient"][1]))]
    lights["colour_jitter"] = min(1.0, 2 * float(lights["colour_jitter"]))
    s["table"]["rgb_jitter"] = min(1.0, 2 * float(s["table"]["rgb_jitter"]))
    s["objects"]["rgb_jitter"] = min(1.0, 2 * float(s["objects"]["rgb_jitter"]))
    s["friction"]["scale"] = _widen(s["friction"]["scale"], 1.5, 1.0, low=0.01)
    s["object_mass"]["scale"] = _widen(s["object_mass"]["scale"], 1.5, 1.0, low=0.01)
    damping = s["joint_damping"]["range"]
    s["joint_damping"]["range"] = [float(damping[0]), 2 * float(damping[1])]
    s["camera"]["position"] = min(0.1, 3 * float(s["camera"]["position"]))
    s["camera"]["orientation_deg"] = min(30.0, 3 * float(s["camera"]["orientation_deg"]))
    s["joint_noise"]["range"] = min(0.5, 2 * float(s["joint_noise"]["range"]))
    return s


def level_section(
    level: str | None, task: str, replacement: Mapping[str, Any] | None = None
) -> tuple[bool, dict[str, Any] | None]:
    """What an evaluation level randomizes.

    Args:
        level: ``nominal``, ``train`` or ``hard``; None: ``train`` with a replacement, else
            ``nominal``.
        task: a registered task name.
        replacement: a randomization section replacing the task's own (``--randomization
            FILE``).

    Returns:
        ``(randomize, section)``: ``nominal`` ``(False, None)``; ``train`` ``(True,
        replacement)`` (None: the task's own section); ``hard`` ``(True, harder(...))`` of
        the task's section with ``replacement``'s kinds in place.
    """
    from trossen_arm_mujoco.tasks import registry
    from trossen_arm_mujoco.tasks.config_key import Source
    from trossen_arm_mujoco.tasks.randomization_schema import (
        RANDOMIZATION_KEY,
        check_randomization,
    )

    if level is None:
        level = "train" if replacement is not None else "nominal"
    if level not in LEVELS:
        raise unknown_name_error("randomization level", str(level), LEVELS)
    if level == "nominal":
        if replacement is not None:
            raise UserError(
                "--randomization FILE randomizes the scene: leave out --randomize nominal"
            )
        return False, None
    if level == "train":
        return True, None if replacement is None else dict(replacement)
    entry = registry.load(task)
    section = entry.load_config()[RANDOMIZATION_KEY]
    if replacement is not None:
        section = check_randomization(Source("--randomization"), section, replacement)
    return True, harder(section)
