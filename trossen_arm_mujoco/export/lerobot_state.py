"""``observation.state`` with joint velocities and efforts, as Trossen's LeRobot plugin has them.

With ``include_velocity`` / ``include_effort`` / ``include_external_effort`` the plugin adds
one ``<joint>.vel`` (rad/s; m/s) / ``<joint>.eff`` (Nm; N) / ``<joint>.ext_eff`` value per
joint after each arm's ``<joint>.pos`` values: the kit is the left follower's values with a
``left_`` prefix, then the right's (42 values with velocity and effort); the Mobile AI adds
the base's ``x.vel``, ``theta.vel``. Velocities are the recorded ``qvel``; efforts are
derived with MuJoCo (:mod:`.joint_efforts`). Only the plugin's layouts (``widowxai``,
``kit14``, ``mobileai``) have these names. The action keeps the positions.

Docs: docs/cli/export.md (joint velocities and efforts in the state).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.data.reader import Episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.joint_efforts import derived_efforts, derived_external_efforts
from trossen_arm_mujoco.robot.layout import EXPORT_LAYOUTS, KIT14_LAYOUT
from trossen_arm_mujoco.robot.lerobot_keys import with_quantity

__all__ = [
    "EXTRA_LAYOUTS",
    "STATE_EXTRAS",
    "arm_count",
    "check_state_extras",
    "state_extras",
    "state_names",
    "state_source",
]

#: The extra values per joint, in the plugin's order: suffix -> the export flag adding them.
STATE_EXTRAS: dict[str, str] = {
    "vel": "include_velocity",
    "eff": "include_effort",
    "ext_eff": "include_external_effort",
}
#: Layouts of the plugin's robots -> arms: ``widowxai`` one, ``kit14`` and ``mobileai`` two.
EXTRA_LAYOUTS: dict[str, int] = {"widowxai": 1, "kit14": 2, "mobileai": 2}

_PER_ARM = 7  # values per arm: 6 joints + the gripper carriage


def arm_count(layout: str) -> int:
    """Arms of a plugin layout (``EXTRA_LAYOUTS``)."""
    return EXTRA_LAYOUTS[layout]


def state_extras(
    include_velocity: bool = False,
    include_effort: bool = False,
    include_external_effort: bool = False,
) -> tuple[str, ...]:
    """The suffixes the flags add, in the plugin's order (``vel``, ``eff``, ``ext_eff``).

    Args:
        include_velocity: add each joint's ``.vel`` (rad/s; m/s).
        include_effort: add each joint's ``.eff`` (Nm; N).
        include_external_effort: add each joint's ``.ext_eff`` (Nm; N).
    """
    chosen = {"vel": include_velocity, "eff": include_effort, "ext_eff": include_external_effort}
    return tuple(s for s in STATE_EXTRAS if chosen[s])


def check_state_extras(layout: str, extras: Sequence[str]) -> tuple[str, ...]:
    """``extras`` checked: known suffixes, in order, and a layout of the plugin's when any."""
    extras = tuple(extras)
    unknown = [e for e in extras if e not in STATE_EXTRAS]
    if unknown or list(extras) != [s for s in STATE_EXTRAS if s in extras]:
        raise UserError(f"state extras must be some of {list(STATE_EXTRAS)} in order, got {extras}")
    if extras and layout not in EXTRA_LAYOUTS:
        flags = " and ".join(f"--{STATE_EXTRAS[e]}" for e in extras)
        raise UserError(
            f"{flags} {'name' if len(extras) > 1 else 'names'} the values as Trossen's "
            f"LeRobot plugin does, in its robots' layouts ({', '.join(EXTRA_LAYOUTS)}); "
            f"leave out --layout {layout} or the flag"
        )
    return extras


def state_names(layout: str, extras: Sequence[str] = ()) -> list[str]:
    """Names of the ``observation.state`` values (the layout's names without extras): per
    arm its positions then each extra, then the layout's other values (the Mobile AI's base)."""
    names = list(EXPORT_LAYOUTS[layout].names)
    if not extras:
        return names
    arms = arm_count(layout)
    out = []
    for side in range(arms):
        pos = names[side * _PER_ARM : (side + 1) * _PER_ARM]
        out += pos
        for suffix in extras:
            out += with_quantity(pos, suffix)
    return out + names[arms * _PER_ARM :]


def _as_vendor16(layout: str, values: np.ndarray) -> np.ndarray:
    """``(T, D)`` recorded rows as the kit's 16 values (``joint_efforts``' scene): the
    Stationary AI's as they are, the Mobile AI's arms (its first 14) and a single arm's 7
    (on both of the kit's arms: the same arm model), each coupled finger repeating its
    gripper."""
    v = np.asarray(values, dtype=np.float64)
    if layout == "mobileai":
        return KIT14_LAYOUT.to_vendor(v[:, : KIT14_LAYOUT.size])
    if layout == "widowxai":
        return KIT14_LAYOUT.to_vendor(np.concatenate([v, v], axis=1))
    return v


def state_source(episode: Episode, layout: str, extras: Sequence[str] = ()) -> np.ndarray:
    """The state of every recorded step, in :func:`state_names` order.

    Args:
        episode: the episode.
        layout: the joint layout (a name of ``robot.layout.EXPORT_LAYOUTS``).
        extras: per-joint values after each arm's positions (``"vel"``, ``"eff"``,
            ``"ext_eff"``).

    Returns:
        float64 ``(T, D)``: positions (rad; m), and the velocities and efforts asked for.
    """
    target = EXPORT_LAYOUTS[layout]
    if layout not in EXTRA_LAYOUTS:  # vendor16: the files' own values
        return np.asarray(episode.qpos, dtype=np.float64)
    positions = np.asarray(target.from_vendor(episode.qpos), dtype=np.float64)
    if not extras:
        return positions
    arms = arm_count(layout)
    width = arms * _PER_ARM
    blocks = {"pos": positions[:, :width]}
    if "vel" in extras:
        blocks["vel"] = np.asarray(target.from_vendor(episode.qvel), dtype=np.float64)[:, :width]
    q16, v16, a16 = (_as_vendor16(layout, x) for x in (episode.qpos, episode.qvel, episode.action))
    if "eff" in extras:
        blocks["eff"] = KIT14_LAYOUT.from_vendor(derived_efforts(q16, v16, a16))[:, :width]
    if "ext_eff" in extras:
        ext = derived_external_efforts(q16, v16, a16, float(episode.dt))
        blocks["ext_eff"] = KIT14_LAYOUT.from_vendor(ext)[:, :width]
    parts = []
    for side in range(arms):
        cols = slice(side * _PER_ARM, (side + 1) * _PER_ARM)
        parts += [blocks["pos"][:, cols], *(blocks[e][:, cols] for e in extras)]
    parts.append(positions[:, width:])  # the Mobile AI's base: x.vel, theta.vel
    return np.concatenate(parts, axis=1)
