"""What the gym envs take from a caller at every step and reset, checked with errors that say
what was expected.

- ``step(action)``: an ``action_space`` sample, a float array of shape (dim,) (or anything
  numpy turns into one: a list, float32/float64/int values). A string, an object, a wrong
  shape or a NaN/inf is an ``InvalidInput`` naming the action space (shape, dtype, bounds).
  The fast path (``ActionMapper.__call__``) checks only a float ndarray of the right shape;
  anything else goes through ``action_array`` here.
- ``reset(options=...)``: None or a dict of the keys of ``RESET_OPTIONS``; an unknown key
  (the accepted ones listed) or a value of the wrong type is an ``InvalidInput``.

``InvalidInput`` is a ``UserError`` (one line; a command prints it without a traceback) and a
``ValueError`` (what gymnasium and numpy users catch for a bad value).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error

__all__ = [
    "RESET_OPTIONS",
    "WRAPPER_OPTIONS",
    "InvalidInput",
    "action_array",
    "describe_space",
    "nonfinite_action",
    "reset_options",
]

#: Keys ``reset(options=...)`` accepts, and what each value must be.
RESET_OPTIONS: dict[str, str] = {
    "object_poses": "a dict {object name: 7 values [x, y, z (m, world), quat w, x, y, z]} "
    "(or None)",
}
#: Keys that wrappers of known tools add to ``reset``'s options for themselves, accepted and
#: ignored: LeRobot's ``lerobot-eval`` marks a new rollout with ``lerobot_new_rollout`` (its
#: ``FreezeAfterEpisodeEnd`` wrapper passes the options on to the env).
WRAPPER_OPTIONS: frozenset[str] = frozenset({"lerobot_new_rollout"})


class InvalidInput(UserError, ValueError):
    """A malformed action or reset option given to a gym env (a ``UserError`` and a
    ``ValueError``)."""


def describe_space(dim: int, low: float = -1.0, high: float = 1.0) -> str:
    """The action space in words: ``Box(-1.0, 1.0, (dim,), float32)``."""
    return f"Box({low}, {high}, ({dim},), float32)"


def action_array(action: Any, dim: int) -> np.ndarray:
    """``action`` as a float64 array (dim,), checked (the slow path: anything that is not a
    float ndarray of shape (dim,)): an ``InvalidInput`` naming the action space for a value
    numpy cannot read as numbers, a bool/complex/object array, or a wrong shape."""
    space = describe_space(dim)
    if isinstance(action, (str, bytes, Mapping)) or action is None:
        raise InvalidInput(
            f"action must be {dim} numbers in [-1, 1] (action space {space}), "
            f"got {type(action).__name__} {action!r:.60}"
        )
    try:
        a = np.asarray(action)
    except (TypeError, ValueError) as exc:  # ragged nested lists, ...
        raise InvalidInput(
            f"action must be {dim} numbers in [-1, 1] (action space {space}), got "
            f"{type(action).__name__} ({str(exc).splitlines()[0][:80]})"
        ) from None
    if a.dtype.kind not in "fiu":
        raise InvalidInput(
            f"action must be {dim} numbers in [-1, 1] (action space {space}), "
            f"got an array of dtype {a.dtype}"
        )
    if a.size != dim or (a.ndim > 1 and max(a.shape) != dim):
        raise InvalidInput(
            f"action must have shape ({dim},) (action space {space}), got shape {a.shape}"
        )
    return a.astype(np.float64).reshape(dim)


def nonfinite_action(a: np.ndarray, dim: int) -> InvalidInput:
    """The error for an action with NaN or inf values (shown, rounded)."""
    return InvalidInput(
        f"action contains NaN or inf: {np.round(a, 4).tolist()} "
        f"(action space {describe_space(dim)}: finite values in [-1, 1])"
    )


def reset_options(options: Any, objects: Mapping[str, Any]) -> dict[str, np.ndarray] | None:
    """``reset``'s ``options`` checked; returns the object poses to place (name -> float64
    (7,) [xyz m, quat wxyz]) or None.

    Args:
        options: None, or a dict whose keys are among ``RESET_OPTIONS`` (and
            ``WRAPPER_OPTIONS``, ignored).
        objects: the scene's objects by name (the names ``object_poses`` may use).
    """
    if options is None:
        return None
    accepted = ", ".join(RESET_OPTIONS)
    if not isinstance(options, Mapping):
        raise InvalidInput(
            f"reset options must be a dict (accepted keys: {accepted}) or None, "
            f"got {type(options).__name__}"
        )
    for key in options:
        if key not in RESET_OPTIONS and key not in WRAPPER_OPTIONS:
            raise InvalidInput(
                f"unknown reset option {key!r:.40}; accepted keys: {accepted} "
                f"(object_poses: {RESET_OPTIONS['object_poses']})"
            )
    poses = options.get("object_poses")
    if poses is None:
        return None
    if not isinstance(poses, Mapping):
        raise InvalidInput(
            f"reset option object_poses must be {RESET_OPTIONS['object_poses']}, "
            f"got {type(poses).__name__}"
        )
    out: dict[str, np.ndarray] = {}
    for name, pose in poses.items():
        if name not in objects:
            err = unknown_name_error("object of reset option object_poses", str(name), objects)
            raise InvalidInput(str(err))
        p = None
        if not isinstance(pose, (str, bytes)):
            try:
                p = np.asarray(pose, dtype=np.float64)
            except (TypeError, ValueError):
                p = None
        if p is None or p.shape != (7,) or not np.isfinite(p).all() or not p[3:].any():
            raise InvalidInput(
                f"reset option object_poses[{name!r}] must be 7 finite numbers [x, y, z (m), "
                f"quat w, x, y, z] with a non-zero quaternion, got {pose!r:.80}"
            )
        out[str(name)] = p
    return out
