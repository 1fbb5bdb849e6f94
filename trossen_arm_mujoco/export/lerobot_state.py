"""``observation.state`` with joint velocities and efforts, as Trossen's LeRobot plugin has them.

The plugin's WidowX AI follower adds, with ``include_velocity`` / ``include_effort``, one
``<joint>.vel`` / ``<joint>.eff`` value per joint after its ``<joint>.pos`` values; LeRobot
gathers every such value of a robot into ``observation.state``, in the robot's order. The kit
(``bi_widowxai_follower``) is the left follower's values with a ``left_`` prefix, then the
right's. So with both flags the state has 42 values::

    left_joint_0.pos .. left_left_carriage_joint.pos,     (rad; the carriage m)
    left_joint_0.vel .. left_left_carriage_joint.vel,     (rad/s; m/s)
    left_joint_0.eff .. left_left_carriage_joint.eff,     (Nm; N)
    right_joint_0.pos .. right_left_carriage_joint.eff

Velocities are the recorded ``qvel``; efforts are derived from the recording with MuJoCo's
actuator model (:mod:`.joint_efforts`). Only the ``kit14`` layout has the plugin's names.
The action keeps the 14 positions.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.joint_efforts import derived_efforts
from trossen_arm_mujoco.robot.layout import LAYOUTS
from trossen_arm_mujoco.robot.lerobot_keys import with_quantity

__all__ = ["STATE_EXTRAS", "check_state_extras", "state_extras", "state_names", "state_source"]

#: The extra values per joint, in the plugin's order: suffix -> the export flag adding them.
STATE_EXTRAS: dict[str, str] = {"vel": "include_velocity", "eff": "include_effort"}

_KIT14 = "kit14"
_PER_ARM = 7  # kit14 values per arm: 6 joints + the gripper carriage


def state_extras(include_velocity: bool = False, include_effort: bool = False) -> tuple[str, ...]:
    """The suffixes the flags add, in the plugin's order: ``()``, ``("vel",)``, ``("eff",)``
    or ``("vel", "eff")``."""
    chosen = {"vel": include_velocity, "eff": include_effort}
    return tuple(s for s in STATE_EXTRAS if chosen[s])


def check_state_extras(layout: str, extras: Sequence[str]) -> tuple[str, ...]:
    """``extras`` checked: known suffixes, in order, and the ``kit14`` layout when any."""
    extras = tuple(extras)
    unknown = [e for e in extras if e not in STATE_EXTRAS]
    if unknown or list(extras) != [s for s in STATE_EXTRAS if s in extras]:
        raise UserError(f"state extras must be some of {list(STATE_EXTRAS)} in order, got {extras}")
    if extras and layout == "mobileai":
        flags = " and ".join(f"--{STATE_EXTRAS[e]}" for e in extras)
        raise UserError(
            f"{flags} {'are' if len(extras) > 1 else 'is'} not supported for Mobile AI "
            "recordings (layout mobileai): the per-joint values are written for the Stationary "
            "AI kit's kit14 layout only; export them without the flag"
        )
    if extras and layout != _KIT14:
        flags = " and ".join(f"--{STATE_EXTRAS[e]}" for e in extras)
        raise UserError(
            f"{flags} {'name' if len(extras) > 1 else 'names'} the values as Trossen's "
            f"LeRobot plugin does, in the kit14 layout; "
            f"leave out --layout {layout} or the flag"
        )
    return extras


def state_names(layout: str, extras: Sequence[str] = ()) -> list[str]:
    """Names of the ``observation.state`` values (the layout's names without extras)."""
    names = list(LAYOUTS[layout].names)
    if not extras:
        return names
    out = []
    for side in range(len(names) // _PER_ARM):
        pos = names[side * _PER_ARM : (side + 1) * _PER_ARM]
        out += pos
        for suffix in extras:
            out += with_quantity(pos, suffix)
    return out


def state_source(episode: Episode, layout: str, extras: Sequence[str] = ()) -> np.ndarray:
    """``(T, D)`` per recorded step, in :func:`state_names` order (float64): positions, and
    the velocities and efforts ``extras`` asks for."""
    target = LAYOUTS[layout]
    if not extras:
        return target.from_vendor(episode.qpos) if layout == _KIT14 else np.asarray(episode.qpos)
    blocks = {"pos": episode.qpos}
    if "vel" in extras:
        blocks["vel"] = episode.qvel
    if "eff" in extras:
        blocks["eff"] = derived_efforts(episode.qpos, episode.qvel, episode.action)
    kit = {k: target.from_vendor(np.asarray(v, dtype=np.float64)) for k, v in blocks.items()}
    parts = []
    for side in range(target.size // _PER_ARM):
        cols = slice(side * _PER_ARM, (side + 1) * _PER_ARM)
        parts += [kit["pos"][:, cols], *(kit[e][:, cols] for e in extras)]
    return np.concatenate(parts, axis=1)
