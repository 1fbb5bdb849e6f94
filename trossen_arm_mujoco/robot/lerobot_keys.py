"""LeRobot's names for the kit's values, defined once: feature keys and joint value names.

Feature keys (datasets, policies and envs): ``observation.state`` (:data:`STATE_KEY`, joint
positions in a layout of ``robot.layout.LAYOUTS``), ``observation.velocity``
(:data:`VELOCITY_KEY`, same layout), ``observation.environment_state`` (:data:`ENV_STATE_KEY`,
7 values per object: xyz m, quat wxyz, world frame), ``observation.images.<camera>``
(:func:`image_key`) and ``action`` (:data:`ACTION_KEY`, joint targets, the state's layout).
Joint value names follow Trossen's LeRobot plugin, ``<joint>.<quantity>``: ``pos`` (rad; m
for a gripper carriage), ``vel`` (rad/s; m/s), ``eff`` and ``ext_eff`` (Nm; N), e.g.
``left_joint_0.pos`` (:func:`joint_value_names`).

Docs: docs/datasets.md (The LeRobot export).
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = [
    "ACTION_KEY",
    "ENV_STATE_KEY",
    "IMAGE_KEY_PREFIX",
    "JOINT_QUANTITIES",
    "STATE_KEY",
    "VELOCITY_KEY",
    "image_camera",
    "image_key",
    "joint_value_names",
    "with_quantity",
]

#: Joint positions (the robot's state), in the dataset's layout.
STATE_KEY = "observation.state"
#: Joint velocities, in the dataset's layout.
VELOCITY_KEY = "observation.velocity"
#: Object poses: 7 values per object (xyz m, quat wxyz), world frame.
ENV_STATE_KEY = "observation.environment_state"
#: Joint targets, in the dataset's layout.
ACTION_KEY = "action"
#: Prefix of a camera's feature key: ``observation.images.<camera>``.
IMAGE_KEY_PREFIX = "observation.images."

#: Suffixes of a joint's values in Trossen's LeRobot plugin: position, velocity, effort,
#: external effort.
JOINT_QUANTITIES: tuple[str, ...] = ("pos", "vel", "eff", "ext_eff")


def image_key(camera: str) -> str:
    """Feature key of a camera: ``observation.images.<camera>``."""
    return f"{IMAGE_KEY_PREFIX}{camera}"


def image_camera(key: str) -> str | None:
    """The camera of an image feature key (``observation.images.cam_high`` -> ``cam_high``);
    None for any other key."""
    return key[len(IMAGE_KEY_PREFIX) :] if key.startswith(IMAGE_KEY_PREFIX) else None


def _check_quantity(quantity: str) -> None:
    if quantity not in JOINT_QUANTITIES:
        raise ValueError(f"quantity must be one of {list(JOINT_QUANTITIES)}, got {quantity!r}")


def joint_value_names(joints: Iterable[str], quantity: str = "pos") -> tuple[str, ...]:
    """``<joint>.<quantity>`` for each joint, e.g. ``left_joint_0.pos``; ``ValueError`` for a
    quantity not in :data:`JOINT_QUANTITIES`."""
    _check_quantity(quantity)
    return tuple(f"{joint}.{quantity}" for joint in joints)


def with_quantity(names: Iterable[str], quantity: str) -> list[str]:
    """Position names renamed to another quantity: ``left_joint_0.pos`` -> ``left_joint_0.vel``
    for ``"vel"``; names without the ``.pos`` suffix (the ``vendor16`` layout's) unchanged."""
    _check_quantity(quantity)
    suffix = ".pos"
    return [n[: -len(suffix)] + f".{quantity}" if n.endswith(suffix) else n for n in names]
