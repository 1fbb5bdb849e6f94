"""The safety floor as the gym envs report it.

The floor itself lives in the robot layer (``robot.safety_floor``): every robot a task
sampler builds keeps its arms above the table tick by tick, whatever drives it; the gym envs
build theirs ``safety_margin`` (task config, m) above ``table_height``. After each step (and
at reset) the env puts the robot's ``floor_report`` into ``info``:

- ``safety_clipped`` (bool): the floor changed a control or a target during the step;
- ``safety_links`` (str): the links it held up, comma-separated ("" when none).

Docs: docs/gym/index.md (safety floor).
"""

from __future__ import annotations

from typing import Any

from trossen_arm_mujoco.robot.safety_floor import FloorReport

__all__ = ["safety_info"]


def safety_info(info: dict[str, Any], report: FloorReport) -> dict[str, Any]:
    """``info`` with ``safety_clipped`` and ``safety_links`` from ``report`` (the robot's
    ``floor_report`` after the step); returns ``info``."""
    links = report.links
    info["safety_clipped"] = bool(links)
    info["safety_links"] = ",".join(links)
    return info
