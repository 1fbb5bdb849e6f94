"""What the gym envs take from a caller at every step and reset, checked with errors that say
what was expected.

``step(action)`` takes an ``action_space`` sample: a float array of shape (dim,) or anything
numpy turns into one. ``reset(options=...)`` takes None or a dict of the keys of
``RESET_OPTIONS``; an object pose is 7 finite numbers [x, y, z (m, world), quat wxyz], its
position inside the task's workspace box, its quaternion of non-zero norm
(:func:`object_pose`, also used by the served kit). Anything else is an ``InvalidInput``: a
``UserError`` (one line) and a ``ValueError``, naming the action space or the accepted
options.

Docs: docs/gym/index.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error

__all__ = [
    "DEFAULT_WORKSPACE",
    "MIN_QUAT_NORM",
    "RESET_OPTIONS",
    "WRAPPER_OPTIONS",
    "InvalidInput",
    "action_array",
    "describe_space",
    "nonfinite_action",
    "object_pose",
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
#: Workspace box (low, high), world frame (m), an object's position must lie in when the
#: caller does not give its task's: ``workspace_low`` / ``workspace_high`` of every shipped
#: task config (``config/*.yaml``; tests/gym/test_object_pose_bounds.py keeps them equal).
DEFAULT_WORKSPACE: tuple[tuple[float, float, float], tuple[float, float, float]] = (
    (-0.8, -0.8, -0.1),
    (0.8, 0.8, 0.9),
)
#: Smallest quaternion norm accepted in an object pose (a zero quaternion is no rotation).
MIN_QUAT_NORM = 1e-6


class InvalidInput(UserError, ValueError):
    """A malformed action or reset option given to a gym env (a ``UserError`` and a
    ``ValueError``)."""


def describe_space(dim: int, low: float = -1.0, high: float = 1.0) -> str:
    """The action space in words: ``Box(-1.0, 1.0, (dim,), float32)``.

    Args:
        dim: number of action values.
        low: lower bound of every value.
        high: upper bound of every value.
    """
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


def _box(low: np.ndarray, high: np.ndarray) -> str:
    """``[-0.8, 0.8] x [-0.8, 0.8] x [-0.1, 0.9] m``: a box in words."""
    return " x ".join(f"[{lo:g}, {hi:g}]" for lo, hi in zip(low, high)) + " m"


def object_pose(pose: Any, what: str, workspace: tuple[Any, Any] | None = None) -> np.ndarray:
    """An object pose, checked.

    Args:
        pose: 7 numbers [x, y, z (m, world), quat w, x, y, z].
        what: what the pose is, starting the error (e.g. ``reset option
            object_poses['box']``).
        workspace: (low, high), (3,) each (m, world); None: ``DEFAULT_WORKSPACE``.

    Returns:
        float64 (7,), the quaternion normalized (as MuJoCo places it).

    Raises:
        InvalidInput: not 7 finite numbers, a position outside ``workspace`` or a
            quaternion of (near) zero norm.
    """
    p = None
    if not isinstance(pose, (str, bytes, Mapping)):
        try:
            p = np.array(pose, dtype=np.float64)  # a copy: normalized below
        except (TypeError, ValueError, OverflowError):
            p = None
    if p is None or p.shape != (7,) or not np.isfinite(p).all():
        raise InvalidInput(
            f"{what} must be 7 finite numbers [x, y, z (m), quat w, x, y, z] with a non-zero "
            f"quaternion, got {pose!r:.80}"
        )
    low, high = (np.asarray(b, dtype=np.float64) for b in (workspace or DEFAULT_WORKSPACE))
    if not ((p[:3] >= low) & (p[:3] <= high)).all():
        raise InvalidInput(
            f"{what}: position {np.round(p[:3], 4).tolist()} is outside the task's workspace "
            f"{_box(low, high)} (workspace_low .. workspace_high)"
        )
    scale = float(np.abs(p[3:]).max())  # scaled first: no overflow (1e308 components)
    unit = p[3:] / scale if scale > 0 else p[3:]
    if scale * float(np.linalg.norm(unit)) < MIN_QUAT_NORM:
        raise InvalidInput(
            f"{what} needs a non-zero quaternion (norm at least {MIN_QUAT_NORM:g}), got "
            f"{p[3:].tolist()}; no rotation is [1, 0, 0, 0]"
        )
    p[3:] = unit / np.linalg.norm(unit)
    return p


def reset_options(
    options: Any, objects: Mapping[str, Any], workspace: tuple[Any, Any] | None = None
) -> dict[str, np.ndarray] | None:
    """``reset``'s ``options`` checked; returns the object poses to place (name -> float64
    (7,) [xyz m, quat wxyz]) or None.

    Args:
        options: None, or a dict whose keys are among ``RESET_OPTIONS`` (and
            ``WRAPPER_OPTIONS``, ignored).
        objects: the scene's objects by name (the names ``object_poses`` may use).
        workspace: (low, high), (3,) each (m, world): the box every object's position must
            lie in (the task's ``workspace_low`` / ``workspace_high``); None:
            ``DEFAULT_WORKSPACE``.
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
        out[str(name)] = object_pose(pose, f"reset option object_poses[{name!r}]", workspace)
    return out
