"""The HDF5 episode layout, defined once and versioned.

One file ``episode_<k>.hdf5`` holds one episode of ``T`` steps (the layout ACT-style training
code reads): root attributes (``sim``, ``task_name``, ``seed``, ``success``, ``dt``,
``camera_names``, ``schema_version``, ...), ``/action`` float32 (T, J) joint targets,
``/reward`` float32 (T,), ``/observations/qpos`` (T, J) rad / m, ``/observations/qvel``
(T, J) rad/s / m/s, ``/observations/env_state`` (T, 7k) object poses (xyz m + quat wxyz) and
``/observations/images/<cam>`` uint8 (T, H, W, 3), chunked one frame per chunk, gzip by
default. ``J`` follows the root attribute ``layout`` (:func:`joint_width`): 16 without it, 7
for a single wxai arm. Version 2 (current) stores every float dataset as float32; version 1
used float64 and uncompressed images. Vendor files have no ``schema_version``.

Docs: docs/datasets.md (The HDF5 episode schema).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import h5py
import numpy as np

from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT

__all__ = [
    "ATTR_KINDS",
    "COMPRESSIONS",
    "DEFAULT_COMPRESSION",
    "ENV_STATE_DIM",
    "EPISODE_FILE_RE",
    "GZIP_LEVEL",
    "JOINT_NAMES",
    "JOINT_UNITS",
    "JOINT_ARRAYS",
    "LAYOUT_WIDTHS",
    "NUM_JOINTS",
    "SINGLE_ARM_LAYOUT",
    "SCHEMA",
    "SCHEMAS",
    "SCHEMA_V1",
    "SCHEMA_V2",
    "SCHEMA_VERSION",
    "VENDOR_DT",
    "ArraySpec",
    "EpisodeSchema",
    "encode_attr",
    "episode_file_name",
    "joint_width",
    "temp_file_name",
]

#: Step period (s) of files without a ``dt`` attribute (vendor files: recorded at 50 Hz), and
#: the writer's default; the recorder passes its task's ``policy_dt``.
VENDOR_DT: float = 0.02

#: Current schema version, stored in the ``schema_version`` root attribute.
SCHEMA_VERSION: int = 2

#: Width of qpos, qvel and action vectors (two arms x (6 joints + 2 fingers)).
NUM_JOINTS: int = VENDOR16_LAYOUT.size

#: The arrays whose width is the joint width of the episode's layout (:func:`joint_width`).
JOINT_ARRAYS: tuple[str, ...] = ("qpos", "qvel", "action")

#: Layout (root attribute ``layout``) of a single wxai arm's recordings: per row
#: ``joint_0`` .. ``joint_5`` (rad), then the gripper (``left_carriage_joint`` travel, m).
SINGLE_ARM_LAYOUT: str = "widowxai"

#: Joint width of the layouts whose rows are not 16 wide.
LAYOUT_WIDTHS: dict[str, int] = {SINGLE_ARM_LAYOUT: 7}


def joint_width(layout: Any = None) -> int:
    """Width of ``qpos``, ``qvel`` and ``action`` rows of an episode whose root attribute
    ``layout`` is ``layout`` (None or absent: the kit's 16)."""
    return LAYOUT_WIDTHS.get(str(layout), NUM_JOINTS) if layout is not None else NUM_JOINTS


#: Width of env_state per object: position xyz (m) + orientation quaternion wxyz; the cube
#: transfer has one object (7 values), peg insertion two (peg then socket, 14 values).
ENV_STATE_DIM: int = 7

#: Joint labels and units in qpos/action order (plots, messages), from the kit layout:
#: ``left_joint_0`` .. ``left_joint_5``, ``left_right_carriage_joint`` (index 6, the coupled
#: finger), ``left_left_carriage_joint`` (index 7, the actuated one), then the right arm.
JOINT_NAMES: tuple[str, ...] = VENDOR16_LAYOUT.names
JOINT_UNITS: tuple[str, ...] = VENDOR16_LAYOUT.units

#: Compression choices for the image datasets.
COMPRESSIONS: tuple[str, ...] = ("none", "gzip", "lzf")

#: Compression of the image datasets unless asked otherwise.
DEFAULT_COMPRESSION: str = "gzip"

#: zlib level of ``"gzip"``, chosen by measurement (``benchmarks/record_episode.py``).
GZIP_LEVEL: int = 1

#: Episode file names: ``episode_<k>.hdf5`` with a non-negative integer ``k``.
EPISODE_FILE_RE = re.compile(r"^episode_(0|[1-9][0-9]*)\.hdf5$")


@dataclass(frozen=True)
class ArraySpec:
    """One numeric dataset of the episode file.

    Attributes:
        path: dataset path inside the file, e.g. ``"observations/qpos"``.
        width: per-step shape; ``()`` for a scalar per step, ``(16,)`` for a vector.
        dtype: dtype the writer stores.
        vendor: True when vendor files have this dataset too (required on load).
        variable: True when the vector length is chosen per episode (``width`` is then the
            default): ``env_state`` holds 7 values per object of the task.
    """

    path: str
    width: tuple[int, ...]
    dtype: np.dtype
    vendor: bool
    variable: bool = False

    def shape(self, num_steps: int) -> tuple[int, ...]:
        """Full dataset shape for an episode of ``num_steps`` steps."""
        return (num_steps, *self.width)


@dataclass(frozen=True)
class EpisodeSchema:
    """Names, shapes and dtypes of one schema version (see the module docstring)."""

    version: int
    arrays: tuple[ArraySpec, ...]
    image_group: str
    image_dtype: np.dtype
    attrs: tuple[str, ...]
    vendor_attrs: tuple[str, ...] = field(default=("sim",))

    def array(self, name: str) -> ArraySpec:
        """The spec of array ``name`` (last path component: ``"qpos"``, ``"action"``...)."""
        for spec in self.arrays:
            if spec.path.rsplit("/", 1)[-1] == name:
                return spec
        raise KeyError(name)

    @property
    def array_names(self) -> tuple[str, ...]:
        """Short names of the numeric arrays, in writer argument order."""
        return tuple(spec.path.rsplit("/", 1)[-1] for spec in self.arrays)

    def image_path(self, camera: str) -> str:
        """Dataset path of the images of ``camera``."""
        return f"{self.image_group}/{camera}"

    def image_shape(self, num_steps: int, height: int, width: int) -> tuple[int, int, int, int]:
        """Image dataset shape ``(T, H, W, 3)``.

        Args:
            num_steps: ``T``, the episode's steps.
            height: ``H`` (pixels).
            width: ``W`` (pixels).
        """
        return (num_steps, height, width, 3)

    @staticmethod
    def image_chunks(height: int, width: int) -> tuple[int, int, int, int]:
        """Image chunking: one frame per chunk, ``(1, H, W, 3)``."""
        return (1, height, width, 3)


def _schema(version: int, dtype: type) -> EpisodeSchema:
    """The layout of ``version``, whose float datasets are all ``dtype``."""
    f = np.dtype(dtype)
    return EpisodeSchema(
        version=version,
        arrays=(
            ArraySpec("observations/qpos", (NUM_JOINTS,), f, vendor=True),
            ArraySpec("observations/qvel", (NUM_JOINTS,), f, vendor=True),
            ArraySpec("action", (NUM_JOINTS,), f, vendor=True),
            ArraySpec("reward", (), f, vendor=False),
            ArraySpec("observations/env_state", (ENV_STATE_DIM,), f, vendor=False, variable=True),
        ),
        image_group="observations/images",
        image_dtype=np.dtype(np.uint8),
        attrs=(
            "sim",
            "task_name",
            "seed",
            "success",
            "episode_len",
            "dt",
            "camera_names",
            "package_version",
            "mujoco_version",
            "schema_version",
        ),
    )


#: Schema version 1: float64 datasets (files recorded before version 2).
SCHEMA_V1 = _schema(1, np.float64)

#: Schema version 2 (current): float32 datasets, like vendor files.
SCHEMA_V2 = _schema(2, np.float32)

#: The schema the writer uses.
SCHEMA: EpisodeSchema = SCHEMA_V2

#: Every schema version the reader understands.
SCHEMAS: dict[int, EpisodeSchema] = {1: SCHEMA_V1, 2: SCHEMA_V2}


#: What each root attribute of the current schema must be (checked by :func:`encode_attr`).
ATTR_KINDS: dict[str, str] = {
    "sim": "a bool",
    "task_name": "a string",
    "seed": "an int",
    "success": "a bool",
    "episode_len": "an int",
    "dt": "a positive float (s)",
    "camera_names": "a list of strings",
    "box_pose": "7 finite floats (xyz + quat wxyz)",
    "package_version": "a string",
    "mujoco_version": "a string",
    "schema_version": "an int",
}


def encode_attr(name: str, value: Any) -> Any:
    """Check root attribute ``name`` and convert it to what h5py stores.

    Attributes not in :data:`ATTR_KINDS` are extras, stored as given (lists of strings as
    an HDF5 string array).

    Raises:
        ValueError: one-line message when ``value`` does not fit ``ATTR_KINDS[name]``.
    """
    kind = ATTR_KINDS.get(name)
    if kind is None:
        if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
            return np.array(list(value), dtype=h5py.string_dtype())
        return value
    is_bool = isinstance(value, (bool, np.bool_))
    encoded: Any = None
    if kind == "a string" and isinstance(value, str):
        encoded = value
    elif kind == "a bool" and is_bool:
        encoded = np.bool_(value)
    elif kind == "an int" and isinstance(value, (int, np.integer)) and not is_bool:
        encoded = np.int64(value)
    elif name == "dt" and isinstance(value, (int, float, np.number)) and not is_bool:
        encoded = np.float64(value) if 0 < value < np.inf else None
    elif name == "camera_names":
        names = [value] if isinstance(value, str) else value
        if isinstance(names, (list, tuple)) and all(isinstance(n, str) for n in names):
            encoded = np.array(list(names), dtype=h5py.string_dtype())
    elif name == "box_pose":
        try:
            pose = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            pose = np.zeros(0)
        if pose.shape == (7,) and np.all(np.isfinite(pose)):
            encoded = pose
    if encoded is None:
        raise ValueError(f"attribute '{name}' must be {kind}, got {value!r:.80}")
    return encoded


def episode_file_name(index: int) -> str:
    """File name of episode ``index``: ``episode_<index>.hdf5``."""
    return f"episode_{index}.hdf5"


def temp_file_name(final_name: str) -> str:
    """Temporary name used while writing ``final_name`` (never matches ``episode_*.hdf5``)."""
    return f".{final_name}.tmp"
