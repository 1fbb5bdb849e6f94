"""SamplerSettings: how a task sampler builds its world, in one checked object.

Every front door that builds a sampler (``tasks.registry.make_sampler``, the gym env, the
recorders, the eval env, the dm_control tasks) describes it with one ``SamplerSettings``
(command mode, cameras, image size, flavour, randomization, looks, safety floor), checked at
construction (a one-line ``UserError`` naming the field). The seed and an existing
dm_control ``Physics`` go to the sampler as their own arguments::

    >>> from trossen_arm_mujoco.tasks import registry
    >>> settings = SamplerSettings(camera_names=("cam_high",), height=240, width=320)
    >>> sampler = registry.make_sampler("sim_transfer_cube", settings)

Docs: docs/reference/tasks.md.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.sim.looks import SceneLooks

__all__ = ["FLAVOURS", "MAX_IMAGE_SIZE", "SamplerSettings"]

#: Flavours of a scene: joint position actuators, or mocap-driven arms (bimanual tasks).
FLAVOURS: tuple[str, ...] = ("joint", "ee")
#: Largest image side (pixels); the model's offscreen buffer bounds it further at render time.
MAX_IMAGE_SIZE = 16384


@dataclass(frozen=True)
class SamplerSettings:
    """How a sampler builds its scene; the defaults build the plain joint-flavour world.

    Attributes:
        command_mode: command mode of the arms (``joint_position``, ``joint_rel_position``,
            ``ee_delta``; checked against the robot's controllers when the sampler is
            built); grippers always take ``joint_position``.
        camera_names: cameras rendered by ``scene.render_images()`` (a tuple of names; a list
            is turned into a tuple). Default: none (no GL context is ever opened).
        height, width: image size of those cameras, pixels (1 to 16384).
        flavour: ``"joint"`` (the config's ``scene``, arms in ``command_mode``) or ``"ee"``
            (the config's ``ee_scene``, mocap-driven arms taking tool poses; bimanual tasks).
        randomize: domain randomization of every episode, as the config's ``randomization``
            section says (default off: the episodes of a sampler without it).
        looks: how the scene is drawn (``sim.looks.SceneLooks``: shadows, arm meshes);
            default ``SceneLooks()``. An existing ``physics`` keeps its own.
        floor_margin: the robot's safety floor (``robot.safety_floor``) lies this far above
            the config's ``table_height``, m (>= 0); default 0.0, the table top itself (the
            gym envs pass the config's ``safety_margin``); None: no floor.
    """

    command_mode: str = "joint_position"
    camera_names: tuple[str, ...] = ()
    height: int = 480
    width: int = 640
    flavour: str = "joint"
    randomize: bool = False
    looks: SceneLooks = field(default_factory=SceneLooks)
    floor_margin: float | None = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.command_mode, str):
            raise UserError(f"command_mode must be a string, got {self.command_mode!r:.60}")
        object.__setattr__(self, "camera_names", _camera_names(self.camera_names))
        for name in ("height", "width"):
            object.__setattr__(self, name, _image_side(name, getattr(self, name)))
        if self.flavour not in FLAVOURS:
            raise unknown_name_error("flavour", str(self.flavour), FLAVOURS)
        if not isinstance(self.randomize, (bool, np.bool_)):
            raise UserError(f"randomize must be True or False, got {self.randomize!r}")
        object.__setattr__(self, "randomize", bool(self.randomize))
        if self.looks is None:
            object.__setattr__(self, "looks", SceneLooks())
        elif not isinstance(self.looks, SceneLooks):
            raise UserError(
                f"looks must be a SceneLooks (sim.looks), got {type(self.looks).__name__} "
                "(e.g. SceneLooks(shadows=False))"
            )
        object.__setattr__(self, "floor_margin", _floor_margin(self.floor_margin))

    def replace(self, **changes: Any) -> SamplerSettings:
        """A copy with ``changes`` (field name -> value), checked like a new one; an unknown
        field is a UserError listing the valid ones."""
        valid = [f.name for f in dataclasses.fields(self)]
        for name in changes:
            if name not in valid:
                raise unknown_name_error("sampler setting", name, valid)
        return dataclasses.replace(self, **changes)


def _camera_names(names: Any) -> tuple[str, ...]:
    if isinstance(names, str):
        names = (names,)
    if not isinstance(names, Sequence) or not all(isinstance(c, str) for c in names):
        raise UserError(
            f"camera_names must be a list of camera names, got {names!r:.60} "
            "(e.g. ('cam_high', 'cam_low'))"
        )
    return tuple(names)


def _image_side(name: str, value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise UserError(f"{name} must be a whole number of pixels, got {value!r:.60}")
    if not 1 <= int(value) <= MAX_IMAGE_SIZE:
        raise UserError(f"{name} must be in [1, {MAX_IMAGE_SIZE}] pixels, got {value}")
    return int(value)


def _floor_margin(value: Any) -> float | None:
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        raise UserError(f"floor_margin must be a number of metres or None, got {value!r:.60}")
    if not math.isfinite(float(value)) or float(value) < 0.0:
        raise UserError(
            f"floor_margin (the safety margin above the table) must be >= 0 m "
            f"(None: no floor), got {value}"
        )
    return float(value)
