"""Where a move group's joints and actuators live in a model, looked up once by name.

``joint_indices`` turns a group's joint names into their ids, their addresses in ``qpos``
and ``qvel`` and their position limits; ``actuator_ids`` turns actuator names into ids;
``root_body_id`` finds the body a group's chain hangs from. An unknown name fails with the
list of valid ones (``names.lookup_id``); a joint of a type the group does not take fails
with the types it does.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id

__all__ = [
    "BALL",
    "FREE",
    "HINGE",
    "POS_DIM",
    "SLIDE",
    "VEL_DIM",
    "JointIndices",
    "actuator_ids",
    "joint_indices",
    "root_body_id",
]

HINGE, SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
BALL, FREE = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)
#: qpos values per joint type (a free joint: position + quaternion).
POS_DIM = {FREE: 7, BALL: 4, SLIDE: 1, HINGE: 1}
#: dofs (qvel values) per joint type.
VEL_DIM = {FREE: 6, BALL: 3, SLIDE: 1, HINGE: 1}


class JointIndices(NamedTuple):
    """The model indices of a group's joints.

    Attributes:
        joint_ids: (n_joints,) joint ids, in the group's order.
        qpos_idx: (pos_dim,) addresses in ``qpos`` (7 for a free joint, else one per joint).
        dof_idx: (vel_dim,) addresses in ``qvel`` (6 for a free joint, else one per joint).
        joint_range: (pos_dim, 2) [low, high] per position value (rad / m); +-inf where the
            joint is unlimited (and for every value of a ball or free joint).
    """

    joint_ids: np.ndarray
    qpos_idx: np.ndarray
    dof_idx: np.ndarray
    joint_range: np.ndarray


def joint_indices(
    model: mujoco.MjModel, group: str, joint_names: Sequence[str], joint_types: Sequence[int]
) -> JointIndices:
    """The indices of ``joint_names`` in ``model``.

    Args:
        model: compiled model.
        group: name of the move group, for messages.
        joint_names: the group's joints, in command order.
        joint_types: the ``mjtJoint`` types the group accepts (e.g. ``(HINGE, SLIDE)``).
    """
    joint_ids = np.array([lookup_id(model, "joint", j) for j in joint_names], dtype=int)
    posadr: list[int] = []
    veladr: list[int] = []
    limits: list[tuple[float, float]] = []
    for jid, jname in zip(joint_ids, joint_names):
        jtype = int(model.jnt_type[jid])
        if jtype not in joint_types:
            kinds = " or ".join(mujoco.mjtJoint(t).name[6:].lower() for t in joint_types)
            raise UserError(f"joint '{jname}' of move group '{group}' is not a {kinds}")
        npos, nvel = POS_DIM[jtype], VEL_DIM[jtype]
        posadr += range(int(model.jnt_qposadr[jid]), int(model.jnt_qposadr[jid]) + npos)
        veladr += range(int(model.jnt_dofadr[jid]), int(model.jnt_dofadr[jid]) + nvel)
        if npos == 1 and model.jnt_limited[jid]:
            limits.append(tuple(model.jnt_range[jid]))
        else:
            limits += [(-np.inf, np.inf)] * npos
    return JointIndices(
        joint_ids,
        np.array(posadr, dtype=int),
        np.array(veladr, dtype=int),
        np.array(limits, dtype=float).reshape(-1, 2),
    )


def actuator_ids(model: mujoco.MjModel, actuator_names: Sequence[str]) -> np.ndarray:
    """(n,) ids of the named actuators, in the given order."""
    return np.array([lookup_id(model, "actuator", a) for a in actuator_names], dtype=int)


def root_body_id(model: mujoco.MjModel, root_body: str | int | None, joint_ids: np.ndarray) -> int:
    """The body a group's chain hangs from.

    Args:
        model: compiled model.
        root_body: a body name or id; None: the parent of the first joint's body, else (no
            joints) the world (0).
        joint_ids: the group's joint ids.

    Returns:
        The body id.
    """
    if isinstance(root_body, (int, np.integer)):
        return int(root_body)
    if root_body is not None:
        return lookup_id(model, "body", root_body)
    if len(joint_ids):
        return int(model.body_parentid[model.jnt_bodyid[joint_ids[0]]])
    return 0
