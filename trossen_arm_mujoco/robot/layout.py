"""The joint layouts of the kit and its arms, defined once: ``vendor16``, ``kit14``,
``mobileai`` and ``widowxai``.

:class:`Vendor16Layout` (``VENDOR16_LAYOUT``) is the 16-value qpos/action layout of the
vendor's HDF5 episodes and of the sim: left arm then right arm, per arm 6 revolute joints
(rad) then the two coupled fingers (m, 0 closed .. 0.044 open): ``right_carriage_joint``
(coupled, index 6 / 14) and ``left_carriage_joint`` (actuated, index 7 / 15; the action's
finger columns hold the gripper command). :class:`Kit14Layout` (``KIT14_LAYOUT``) is the real
kit's 14 values (per arm 6 joints and the gripper), as Trossen's LeRobot plugin and the
driver take them; :class:`WidowXAILayout` one arm's 7; the Mobile AI's adds the base.
``EXPORT_LAYOUTS`` maps the ``export --layout`` names to them.

Docs: docs/datasets.md (The layouts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trossen_arm_mujoco.robot.lerobot_keys import joint_value_names

__all__ = [
    "ARM_JOINTS",
    "ARM_VALUES",
    "EE_LAYOUT",
    "EXPORT_LAYOUTS",
    "FINGER_JOINTS",
    "GRIPPER_CLOSED",
    "GRIPPER_OPEN",
    "KIT14_LAYOUT",
    "LAYOUTS",
    "MOBILEAI_LAYOUT",
    "SIDES",
    "START_ARM_POSE",
    "VENDOR16_LAYOUT",
    "WIDOWXAI_LAYOUT",
    "EELayout",
    "Kit14Layout",
    "MobileAILayout",
    "Vendor16Layout",
    "WidowXAILayout",
    "kit_joint_commands",
]

#: Gripper finger travel (m): fully open; and closed on the 25 mm cube.
GRIPPER_OPEN: float = 0.044
GRIPPER_CLOSED: float = 0.012

#: Arm joints of one wxai arm, then its finger joints (MJCF names without prefix).
ARM_JOINTS: tuple[str, ...] = tuple(f"joint_{i}" for i in range(6))
FINGER_JOINTS: tuple[str, ...] = ("right_carriage_joint", "left_carriage_joint")
ARM_VALUES: tuple[str, ...] = ARM_JOINTS + FINGER_JOINTS
SIDES: tuple[str, ...] = ("left", "right")


def _joint_commands(layout, action: np.ndarray) -> dict[str, np.ndarray]:
    """Robot commands of a joint action in ``layout`` (anything with ``arm(side)`` and
    ``gripper_index(side)``): 6 joint targets per arm, one gripper target per gripper."""
    a = np.asarray(action, dtype=float)
    out: dict[str, np.ndarray] = {}
    for side in SIDES:
        out[f"{side}_arm"] = a[layout.arm(side)]
        g = layout.gripper_index(side)
        out[f"{side}_gripper"] = a[g : g + 1]
    return out


@dataclass(frozen=True)
class Vendor16Layout:
    """The vendor's 16-value layout (``vendor16``): names, units and slices of the vector
    (and the per-arm 8-value blocks).

    Attributes:
        names: 16 labels ``"<side>_<joint>"``, e.g. ``"left_joint_0"``,
            ``"left_right_carriage_joint"``.
        units: 16 units, ``"rad"`` or ``"m"``.
        groups: move-group name -> slice of the 16 values (``left_arm`` 0:6, ``left_gripper``
            6:8, ``right_arm`` 8:14, ``right_gripper`` 14:16): the robot configs' group names.
    """

    size: int = 16

    @property
    def names(self) -> tuple[str, ...]:
        """The 16 value names, ``left_joint_0`` ... ``right_right_finger``."""
        return tuple(f"{side}_{joint}" for side in SIDES for joint in ARM_VALUES)

    @property
    def units(self) -> tuple[str, ...]:
        """Unit of each of the 16 values: ``rad`` for arm joints, ``m`` for fingers."""
        return (("rad",) * 6 + ("m",) * 2) * 2

    @property
    def groups(self) -> dict[str, slice]:
        """Move group id -> slice of the 16 values (arm: 6 joints, gripper: 2 fingers)."""
        return {
            "left_arm": slice(0, 6),
            "left_gripper": slice(6, 8),
            "right_arm": slice(8, 14),
            "right_gripper": slice(14, 16),
        }

    def arm(self, side: str) -> slice:
        """The 6 joint values of ``side`` ("left" or "right")."""
        return self.groups[f"{side}_arm"]

    def fingers(self, side: str) -> slice:
        """The 2 finger values of ``side``."""
        return self.groups[f"{side}_gripper"]

    def gripper_index(self, side: str) -> int:
        """Index of the actuated finger (``left_carriage_joint``): 7 / 15."""
        return self.fingers(side).start + 1

    def driver_slice(self, side: str) -> slice:
        """The 7 values sent to a real arm: 6 joints + the coupled finger (0:7 / 8:15)."""
        start = self.arm(side).start
        return slice(start, start + 7)

    def split(self, vector: np.ndarray) -> dict[str, np.ndarray]:
        """Per move group views of a (16,) vector (joint values, both fingers)."""
        v = np.asarray(vector)
        return {group: v[s] for group, s in self.groups.items()}

    def joint_commands(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """A (16,) joint action as robot commands: 6 joint targets per arm and one gripper
        target (the actuated finger's value) per gripper."""
        return _joint_commands(self, action)


#: The vendor's 16-value layout of the Stationary AI kit (both arms): qpos, HDF5 episodes.
VENDOR16_LAYOUT = Vendor16Layout()


@dataclass(frozen=True)
class Kit14Layout:
    """The real kit's 14-value layout (``kit14``): what Trossen's LeRobot plugin for the kit
    (``bi_widowxai_follower_robot``) reads and commands, and what the real driver takes.

    Per arm, left then right: ``joint_0`` .. ``joint_5`` (rad), then the gripper as the
    ``left_carriage_joint`` travel (m, 0 closed .. 0.044 open); the second finger
    (``right_carriage_joint``) is coupled to it and has no value of its own. Labels are
    ``"<side>_<joint>.pos"``: ``left_joint_0.pos`` .. ``left_left_carriage_joint.pos``, then
    ``right_...``.
    """

    size: int = 14

    @property
    def names(self) -> tuple[str, ...]:
        """The 14 value names of the real kit, ``left_joint_0.pos`` ...
        ``right_left_carriage_joint.pos``."""
        arm = ARM_JOINTS + ("left_carriage_joint",)
        return joint_value_names(f"{side}_{joint}" for side in SIDES for joint in arm)

    @property
    def units(self) -> tuple[str, ...]:
        """Unit of each of the 14 values: ``rad`` for arm joints, ``m`` for the carriage."""
        return (("rad",) * 6 + ("m",)) * 2

    def arm(self, side: str) -> slice:
        """The 6 joint values of ``side``: 0:6 / 7:13."""
        start = SIDES.index(side) * 7
        return slice(start, start + 6)

    def gripper_index(self, side: str) -> int:
        """Index of the gripper (carriage) value of ``side``: 6 / 13."""
        return SIDES.index(side) * 7 + 6

    @property
    def vendor_index(self) -> np.ndarray:
        """Indices into the 16-value layout of the 14 values (the actuated finger, 7 / 15,
        stands for the gripper)."""
        return np.array([*range(0, 6), 7, *range(8, 14), 15])

    def from_vendor(self, values: np.ndarray) -> np.ndarray:
        """``(..., 16)`` ``vendor16`` values -> ``(..., 14)`` (a copy)."""
        v = np.asarray(values)
        if v.shape[-1:] != (VENDOR16_LAYOUT.size,):
            raise ValueError(f"expected {VENDOR16_LAYOUT.size} values per row, got shape {v.shape}")
        return v[..., self.vendor_index]

    def to_vendor(self, values: np.ndarray) -> np.ndarray:
        """``(..., 14)`` -> ``(..., 16)``: the coupled finger (6 / 14) repeats the gripper
        value, as the real gripper's second finger follows the first."""
        v = np.asarray(values)
        if v.shape[-1:] != (self.size,):
            raise ValueError(f"expected {self.size} values per row, got shape {v.shape}")
        out = np.empty((*v.shape[:-1], VENDOR16_LAYOUT.size), dtype=v.dtype)
        out[..., self.vendor_index] = v
        out[..., [6, 14]] = v[..., [6, 13]]
        return out

    def joint_commands(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """A (14,) joint action as robot commands: 6 joint targets per arm and one gripper
        target per gripper (the same commands as the 16-value action it stands for)."""
        return _joint_commands(self, action)


#: The real kit's 14-value layout (LeRobot datasets and policies, the real driver).
KIT14_LAYOUT = Kit14Layout()


@dataclass(frozen=True)
class MobileAILayout(Kit14Layout):
    """The Mobile AI's 16 values (``mobileai``), as Trossen's LeRobot plugin for it
    (``mobileai_robot``) reads and commands them: the two arms' 14 values as
    :class:`Kit14Layout` (0:14), then the base's ``x.vel`` (m/s, forward) and ``theta.vel``
    (rad/s, counter-clockwise seen from above) (14:16): measured in the state, commanded in
    the action. Mobile episodes are recorded in this layout (HDF5 attribute ``layout``)."""

    size: int = 16

    @property
    def names(self) -> tuple[str, ...]:
        """``left_joint_0.pos`` ... ``right_left_carriage_joint.pos``, ``x.vel``,
        ``theta.vel``."""
        return KIT14_LAYOUT.names + BASE_VALUES

    @property
    def units(self) -> tuple[str, ...]:
        """``rad`` / ``m`` for the arms' values, then ``m/s`` and ``rad/s``."""
        return KIT14_LAYOUT.units + ("m/s", "rad/s")

    @property
    def base(self) -> slice:
        """The base's [x.vel, theta.vel]: 14:16."""
        return slice(14, 16)

    def from_vendor(self, values: np.ndarray) -> np.ndarray:
        """Mobile episodes are stored in this layout already: ``(..., 16)`` values as they
        are (a copy)."""
        v = np.asarray(values)
        if v.shape[-1:] != (self.size,):
            raise ValueError(f"expected {self.size} values per row, got shape {v.shape}")
        return v.copy()

    def to_vendor(self, values: np.ndarray) -> np.ndarray:
        """Not defined: the Stationary AI's 16 values have no base."""
        raise ValueError("the mobileai layout has no vendor16 equivalent (it has a base)")

    def commands(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """A (16,) action as robot commands: 6 joint targets per arm, one gripper target per
        gripper, ``base`` [x.vel, theta.vel]."""
        a = np.asarray(action, dtype=float)
        if a.shape != (self.size,):
            raise ValueError(f"a Mobile AI action has {self.size} values, got shape {a.shape}")
        out = _joint_commands(self, a[:14])
        out["base"] = a[self.base]
        return out


@dataclass(frozen=True)
class WidowXAILayout:
    """One WidowX AI arm's 7 values (``widowxai``), as Trossen's LeRobot plugin for a single
    follower (``widowxai_follower_robot``) reads and commands them: ``joint_0.pos`` ..
    ``joint_5.pos`` (rad), ``left_carriage_joint.pos`` (the gripper, m). A single arm's
    recordings (HDF5 attribute ``layout`` ``widowxai``) are stored in this layout already."""

    size: int = 7

    @property
    def names(self) -> tuple[str, ...]:
        """``joint_0.pos`` .. ``joint_5.pos``, ``left_carriage_joint.pos``."""
        return joint_value_names(ARM_JOINTS + ("left_carriage_joint",))

    @property
    def units(self) -> tuple[str, ...]:
        """``rad`` for the 6 joints, ``m`` for the carriage."""
        return ("rad",) * 6 + ("m",)

    def from_vendor(self, values: np.ndarray) -> np.ndarray:
        """A single arm's recorded ``(..., 7)`` values as they are (a copy)."""
        v = np.asarray(values)
        if v.shape[-1:] != (self.size,):
            raise ValueError(f"expected {self.size} values per row, got shape {v.shape}")
        return v.copy()


#: One WidowX AI arm's 7-value layout (``widowxai_follower_robot``).
WIDOWXAI_LAYOUT = WidowXAILayout()


#: The base's two values in Trossen's ``mobileai_robot`` (trossen_slate's velocities).
BASE_VALUES: tuple[str, ...] = ("x.vel", "theta.vel")
#: The Mobile AI's 16-value layout (its recordings, LeRobot datasets and policies).
MOBILEAI_LAYOUT = MobileAILayout()

#: Layouts of a joint action or state vector by name, as ``export --layout`` takes them:
#: ``kit14`` (the real kit's, the default toward LeRobot), ``vendor16`` (the HDF5 files')
#: and ``mobileai`` (the Mobile AI's, chosen for its recordings).
LAYOUTS: dict[str, Kit14Layout | Vendor16Layout] = {
    "kit14": KIT14_LAYOUT,
    "vendor16": VENDOR16_LAYOUT,
    "mobileai": MOBILEAI_LAYOUT,
}
#: The layouts ``export --layout`` writes: :data:`LAYOUTS` and ``widowxai`` (one arm's,
#: chosen for a single arm's recordings).
EXPORT_LAYOUTS: dict[str, Kit14Layout | Vendor16Layout | WidowXAILayout] = {
    **LAYOUTS,
    "widowxai": WIDOWXAI_LAYOUT,
}


def kit_joint_commands(action: np.ndarray) -> dict[str, np.ndarray]:
    """Robot commands of a joint action in either layout: 16 values (the qpos layout) or 14
    (the real kit's). ``ValueError`` for any other length."""
    size = np.shape(action)[-1] if np.ndim(action) else 0
    if np.ndim(action) == 1 and size == KIT14_LAYOUT.size:
        return KIT14_LAYOUT.joint_commands(action)
    if np.ndim(action) == 1 and size == VENDOR16_LAYOUT.size:
        return VENDOR16_LAYOUT.joint_commands(action)
    raise ValueError(
        f"a joint action of the kit has {KIT14_LAYOUT.size} values (the real kit's layout) "
        f"or {VENDOR16_LAYOUT.size} (the qpos layout), got shape {np.shape(action)}"
    )


@dataclass(frozen=True)
class EELayout:
    """The 16-value end-effector action of the mocap env: per arm ``[xyz (m), quat wxyz,
    gripper (m)]``, left then right (world frame; gripper = finger travel)."""

    size: int = 16

    @property
    def groups(self) -> dict[str, slice]:
        """Move group id -> slice of the 16 values (arm: tool pose [xyz m, quat wxyz],
        gripper: 1 opening, m)."""
        return {
            "left_arm": slice(0, 7),
            "left_gripper": slice(7, 8),
            "right_arm": slice(8, 15),
            "right_gripper": slice(15, 16),
        }

    def commands(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """A (16,) EE action as robot commands (tool pose per arm, one gripper value)."""
        a = np.asarray(action, dtype=float)
        return {group: a[s] for group, s in self.groups.items()}


#: The layout of the end-effector (mocap) action.
EE_LAYOUT = EELayout()

#: Arm pose at episode start, 16 values in the ``vendor16`` layout.
START_ARM_POSE: list[float] = [
    0.0,
    np.pi / 12,
    np.pi / 12,
    0.0,
    0.0,
    0.0,
    GRIPPER_OPEN,
    GRIPPER_OPEN,
    0.0,
    np.pi / 12,
    np.pi / 12,
    0.0,
    0.0,
    0.0,
    GRIPPER_OPEN,
    GRIPPER_OPEN,
]
