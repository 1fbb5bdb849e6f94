"""Checks of the robot layer's inputs: model/data pairs, control vectors, velocity limits.

Each raises a one-line ``UserError`` that says what is wrong.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = ["check_data_fits", "check_velocity_limits", "finite", "model_and_data", "vector"]


def model_and_data(source) -> tuple[mujoco.MjModel, mujoco.MjData | None]:
    """(model, data) of an ``MjModel`` (data None) or an ``MjData`` (its model)."""
    if isinstance(source, mujoco.MjData):
        return source.model, source
    if isinstance(source, mujoco.MjModel):
        return source, None
    raise UserError(f"expected a mujoco.MjModel or mujoco.MjData, got {type(source).__name__}")


def check_data_fits(model: mujoco.MjModel, data: mujoco.MjData, what: str) -> None:
    """UserError unless ``data`` was made for a model of ``model``'s sizes.

    Args:
        model: the model the caller works with.
        data: the data handed in.
        what: what the caller is, named in the error.
    """
    if not isinstance(data, mujoco.MjData):
        raise UserError(f"{what}: expected a mujoco.MjData, got {type(data).__name__}")
    for size in ("nq", "nv", "nu", "nbody", "nmocap"):
        if getattr(data.model, size) != getattr(model, size):
            raise UserError(
                f"{what}: the MjData belongs to another model ({size} "
                f"{getattr(data.model, size)} != {getattr(model, size)}); bind the data of the "
                "model the group was built on"
            )


def vector(name: str, value, size: int) -> np.ndarray:
    """``value`` as a finite float vector of ``size`` values, else a one-line UserError.

    Args:
        name: what the value is, named in the error.
        value: anything ``np.asarray`` takes.
        size: the number of values required.

    Returns:
        float ``(size,)``.
    """
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise UserError(f"{name}: expected {size} control values, got {v.size}")
    return finite(name, v)


def finite(name: str, value: np.ndarray) -> np.ndarray:
    """``value`` (a float vector) when every value is finite, else a one-line UserError."""
    # v.v is finite iff every value is (or a huge one overflowed: check exactly then)
    if not math.isfinite(value.dot(value)) and not np.isfinite(value).all():
        raise UserError(f"{name}: command contains NaN or inf: {np.round(value, 4).tolist()}")
    return value


def check_velocity_limits(name: str, limits: Sequence[float], size: int) -> np.ndarray:
    """``limits`` as a (size,) array of positive, finite speeds, else a one-line UserError.

    Args:
        name: move group name, for the message.
        limits: max speed per control value (rad/s for hinge joints, m/s for slide joints).
        size: the group's number of control values.
    """
    v = np.asarray(limits, dtype=float).reshape(-1)
    if v.shape != (size,):
        raise UserError(
            f"{name}: expected {size} velocity limits (one per control value), got {v.size}"
        )
    if not np.all(np.isfinite(v) & (v > 0)):
        raise UserError(f"{name}: velocity limits must be positive and finite, got {v.tolist()}")
    return v
