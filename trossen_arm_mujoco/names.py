"""Model name lookup, done once at construction, with errors that list the valid names.

Docs: docs/reference/robot-sim.md.
"""

from __future__ import annotations

import mujoco

from trossen_arm_mujoco.errors import unknown_name_error

__all__ = ["lookup_id", "names_of"]

_OBJ = {
    "body": (mujoco.mjtObj.mjOBJ_BODY, "nbody"),
    "joint": (mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
    "geom": (mujoco.mjtObj.mjOBJ_GEOM, "ngeom"),
    "site": (mujoco.mjtObj.mjOBJ_SITE, "nsite"),
    "camera": (mujoco.mjtObj.mjOBJ_CAMERA, "ncam"),
    "actuator": (mujoco.mjtObj.mjOBJ_ACTUATOR, "nu"),
    "equality": (mujoco.mjtObj.mjOBJ_EQUALITY, "neq"),
    "key": (mujoco.mjtObj.mjOBJ_KEY, "nkey"),
    "light": (mujoco.mjtObj.mjOBJ_LIGHT, "nlight"),
    "material": (mujoco.mjtObj.mjOBJ_MATERIAL, "nmat"),
}


def names_of(model: mujoco.MjModel, kind: str) -> list[str]:
    """All non-empty names of one kind ("body", "joint", "geom", "site", "camera", ...)."""
    obj, count = _OBJ[kind]
    out = []
    for i in range(getattr(model, count)):
        name = mujoco.mj_id2name(model, obj, i)
        if name:
            out.append(name)
    return out


def lookup_id(model: mujoco.MjModel, kind: str, name: str) -> int:
    """Id of a named model element; a UserError listing the valid names when unknown.

    Args:
        model: compiled model.
        kind: the element type (``"body"``, ``"joint"``, ``"site"``, ``"geom"``,
            ``"actuator"``, ...).
        name: its name.
    """
    obj, _ = _OBJ[kind]
    idx = mujoco.mj_name2id(model, obj, name)
    if idx < 0:
        raise unknown_name_error(kind, name, names_of(model, kind))
    return int(idx)
