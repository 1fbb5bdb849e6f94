"""Loading episode files with validation, and finding them in a folder.

:func:`load_episode` reads the small arrays (qpos, qvel, action, reward, env_state) and
checks the whole layout; images stay on disk and are read one frame at a time
(:meth:`Episode.open_frames`, :meth:`Episode.iter_frames`) unless ``load_images=True``.
Both files of this package and vendor files (float32, no extras, no attributes) load;
every problem raises :class:`EpisodeError` with a one-line message.

Docs: docs/datasets.md, docs/reference/data.md.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS
from trossen_arm_mujoco.data.schema import (
    EPISODE_FILE_RE,
    JOINT_ARRAYS,
    SCHEMA,
    SCHEMAS,
    episode_file_name,
    joint_width,
)
from trossen_arm_mujoco.data.schema import VENDOR_DT as DT
from trossen_arm_mujoco.errors import UserError

__all__ = [
    "Episode",
    "EpisodeError",
    "FrameReader",
    "episode_path",
    "iter_episodes",
    "list_episodes",
    "load_episode",
    "resolve_data_dir",
]


class EpisodeError(UserError):
    """An episode file is missing, unreadable or does not follow the schema."""


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


@dataclass
class Episode:
    """One loaded episode.

    Attributes:
        path: the file.
        qpos, qvel, action: float64 ``(T, 16)`` (rad, rad/s; fingers m, m/s); ``(T, 7)``
            for a single wxai arm's recording (attribute ``layout`` ``"widowxai"``:
            ``joint_0`` .. ``joint_5``, then the gripper).
        reward: float64 ``(T,)``, None for vendor files.
        env_state: float64 ``(T, 7k)`` object poses (xyz + quat wxyz each; the cube
            transfer: k = 1), None for vendor files.
        camera_names: cameras with an image dataset, in recording order.
        image_shapes: ``{camera: (H, W, 3)}``.
        attrs: root attributes as plain Python values (str, int, float, bool, list).
        is_vendor: True when the file has no ``schema_version`` (vendor recording).
        images: ``{camera: uint8 (T, H, W, 3)}`` when loaded with ``load_images=True``.
    """

    path: Path
    qpos: np.ndarray
    qvel: np.ndarray
    action: np.ndarray
    reward: np.ndarray | None
    env_state: np.ndarray | None
    camera_names: list[str]
    image_shapes: dict[str, tuple[int, int, int]]
    attrs: dict[str, Any]
    is_vendor: bool
    images: dict[str, np.ndarray] | None = field(default=None, repr=False)

    def __repr__(self) -> str:
        return (
            f"Episode(path={str(self.path)!r}, num_steps={self.num_steps}, "
            f"camera_names={self.camera_names}, is_vendor={self.is_vendor})"
        )

    @property
    def num_steps(self) -> int:
        """Number of steps ``T``."""
        return int(self.qpos.shape[0])

    @property
    def index(self) -> int | None:
        """``k`` of ``episode_<k>.hdf5``, None for other file names."""
        match = EPISODE_FILE_RE.match(self.path.name)
        return int(match.group(1)) if match else None

    @property
    def dt(self) -> float:
        """Step period (s): the ``dt`` attribute, else ``VENDOR_DT`` (0.02 s)."""
        return float(self.attrs.get("dt", DT))

    @property
    def box_pose(self) -> np.ndarray | None:
        """Initial cube pose, float64 (7,) xyz + quat wxyz; None when not recorded."""
        pose = self.attrs.get("box_pose")
        return None if pose is None else np.asarray(pose, dtype=np.float64)

    @property
    def has_images(self) -> bool:
        """True when at least one camera was recorded."""
        return bool(self.camera_names)

    def open_frames(self) -> FrameReader:
        """Open the file for reading frames; use as a context manager."""
        return FrameReader(self)

    def read_frame(self, camera: str, t: int) -> np.ndarray:
        """Frame ``t`` of ``camera``, uint8 ``(H, W, 3)`` (opens the file once per call)."""
        with self.open_frames() as frames:
            return frames.read(camera, t)

    def iter_frames(self, camera: str) -> Iterator[np.ndarray]:
        """Frames of ``camera`` in order, uint8 ``(H, W, 3)`` each, one in memory at a time."""
        with self.open_frames() as frames:
            for t in range(self.num_steps):
                yield frames.read(camera, t)


class FrameReader:
    """Open handle on an episode file that reads single frames.

    Memory stays at one frame per :meth:`read`; the file is closed by :meth:`close` or on
    leaving the ``with`` block.
    """

    def __init__(self, episode: Episode) -> None:
        self.episode = episode
        try:
            self._file = h5py.File(episode.path, "r")
        except OSError as exc:
            raise EpisodeError(f"{episode.path}: cannot open: {_one_line(exc)}") from None

    def __enter__(self) -> FrameReader:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Close the file (idempotent)."""
        self._file.close()

    def read(self, camera: str, t: int) -> np.ndarray:
        """Frame ``t`` of ``camera``: uint8 ``(H, W, 3)``."""
        ep = self.episode
        if camera not in ep.camera_names:
            raise EpisodeError(
                f"{ep.path.name}: no camera '{camera}'; cameras: {', '.join(ep.camera_names)}"
            )
        if not 0 <= t < ep.num_steps:
            raise EpisodeError(f"{ep.path.name}: step {t} out of range 0..{ep.num_steps - 1}")
        try:
            return self._file[SCHEMA.image_path(camera)][t]
        except (OSError, KeyError, ValueError) as exc:
            raise EpisodeError(
                f"{ep.path}: cannot read frame {t} of '{camera}' (corrupt file?): {_one_line(exc)}"
            ) from None

    def step(self, t: int, cameras: Iterable[str] | None = None) -> dict[str, np.ndarray]:
        """Frames of step ``t``: ``{camera: uint8 (H, W, 3)}``."""
        cams = self.episode.camera_names if cameras is None else list(cameras)
        return {cam: self.read(cam, t) for cam in cams}


def _decode_attr(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray):
        return [_decode_attr(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return _decode_attr(value.item())
    return value


def _order_cameras(present: Iterable[str], listed: list[str] | None) -> list[str]:
    """Recording order: the ``camera_names`` attribute, else the Stationary AI order."""
    present = set(present)
    preferred = listed if listed is not None else STATIONARY_CAMERAS
    first = [cam for cam in preferred if cam in present]
    return first + sorted(present - set(first))


def load_episode(path: str | os.PathLike[str], load_images: bool = False) -> Episode:
    """Load and validate one episode file.

    Args:
        path: an ``episode_<k>.hdf5`` file (this package's schema or a vendor recording).
        load_images: also read every image into :attr:`Episode.images` (large: T*H*W*3
            bytes per camera); otherwise read frames lazily.

    Raises:
        EpisodeError: missing file, not HDF5 / truncated / corrupt, missing dataset, wrong
            shape or dtype, length mismatch, NaN/inf, missing attribute, newer schema.
    """
    path = Path(path).expanduser()
    if not path.exists():
        raise EpisodeError(f"episode file not found: {path}")
    if not path.is_file():
        raise EpisodeError(f"{path} is not a file")
    try:
        with h5py.File(path, "r") as f:
            return _load(f, path, load_images)
    except EpisodeError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise EpisodeError(
            f"{path}: not a readable HDF5 episode file (truncated or corrupt?): {_one_line(exc)}"
        ) from None


def _load(f: h5py.File, path: Path, load_images: bool) -> Episode:
    attrs = {name: _decode_attr(value) for name, value in f.attrs.items()}
    version = attrs.get("schema_version")
    is_vendor = version is None
    if not is_vendor and version not in SCHEMAS:
        raise EpisodeError(
            f"{path}: schema_version {version} is not supported (this package reads "
            f"{sorted(SCHEMAS)}); upgrade trossen-arm-mujoco"
        )
    schema = SCHEMA if is_vendor else SCHEMAS[version]
    if not is_vendor:
        missing = [name for name in schema.attrs if name not in attrs]
        if missing:
            raise EpisodeError(f"{path}: missing root attributes {missing}")

    arrays: dict[str, np.ndarray | None] = {}
    num_steps: int | None = None
    first = ""
    joints = (joint_width(attrs.get("layout")),)  # the rows' width in the file's layout
    for name, spec in zip(schema.array_names, schema.arrays, strict=True):
        node = f.get(spec.path)
        if node is None:
            if is_vendor and not spec.vendor:
                arrays[name] = None
                continue
            raise EpisodeError(f"{path}: missing dataset /{spec.path}")
        width = joints if name in JOINT_ARRAYS else spec.width
        want = "(T, " + ", ".join(map(str, width)) + ")" if width else "(T,)"
        if not isinstance(node, h5py.Dataset):
            raise EpisodeError(f"{path}: /{spec.path} is a group, expected a dataset {want}")
        width_ok = node.shape[1:] == width or (
            spec.variable and node.ndim == 2 and node.shape[1] % spec.width[0] == 0 < node.shape[1]
        )
        if node.ndim != 1 + len(width) or not width_ok:
            raise EpisodeError(f"{path}: /{spec.path} has shape {node.shape}, expected {want}")
        if node.dtype.kind != "f":
            raise EpisodeError(
                f"{path}: /{spec.path} has dtype {node.dtype}, expected floating point"
            )
        if num_steps is None:
            num_steps, first = node.shape[0], spec.path
        elif node.shape[0] != num_steps:
            raise EpisodeError(
                f"{path}: length mismatch: /{first} has {num_steps} steps, "
                f"/{spec.path} has {node.shape[0]}"
            )
        data = np.asarray(node[()], dtype=np.float64)
        bad = ~np.isfinite(data)
        if bad.any():
            step = int(np.argwhere(bad)[0][0])
            raise EpisodeError(f"{path}: /{spec.path} contains NaN or inf (first at step {step})")
        arrays[name] = data
    assert num_steps is not None
    if num_steps == 0:
        raise EpisodeError(f"{path}: episode has no steps")
    if "episode_len" in attrs and attrs["episode_len"] != num_steps:
        raise EpisodeError(
            f"{path}: attribute episode_len={attrs['episode_len']} but datasets have "
            f"{num_steps} steps"
        )

    cameras, shapes = _check_images(f, path, num_steps, attrs.get("camera_names"))
    images = None
    if load_images:
        images = {cam: f[SCHEMA.image_path(cam)][()] for cam in cameras}
    return Episode(
        path=path,
        qpos=arrays["qpos"],
        qvel=arrays["qvel"],
        action=arrays["action"],
        reward=arrays["reward"],
        env_state=arrays["env_state"],
        camera_names=cameras,
        image_shapes=shapes,
        attrs=attrs,
        is_vendor=is_vendor,
        images=images,
    )


def _check_images(
    f: h5py.File, path: Path, num_steps: int, listed: list[str] | None
) -> tuple[list[str], dict[str, tuple[int, int, int]]]:
    group = f.get(SCHEMA.image_group)
    if group is not None and not isinstance(group, h5py.Group):
        raise EpisodeError(f"{path}: /{SCHEMA.image_group} is a dataset, expected a group")
    shapes: dict[str, tuple[int, int, int]] = {}
    for cam, node in (group or {}).items():
        where = f"{path}: /{SCHEMA.image_path(cam)}"
        if not isinstance(node, h5py.Dataset):
            raise EpisodeError(f"{where} is a group, expected a dataset (T, H, W, 3)")
        if node.ndim != 4 or node.shape[3] != 3:
            raise EpisodeError(f"{where} has shape {node.shape}, expected (T, H, W, 3)")
        if node.dtype != SCHEMA.image_dtype:
            raise EpisodeError(f"{where} has dtype {node.dtype}, expected uint8")
        if node.shape[0] != num_steps:
            raise EpisodeError(
                f"{path}: length mismatch: qpos has {num_steps} steps, "
                f"/{SCHEMA.image_path(cam)} has {node.shape[0]}"
            )
        shapes[cam] = tuple(node.shape[1:])
    if listed is not None:
        listed = [listed] if isinstance(listed, str) else list(listed)
        missing = [cam for cam in listed if cam not in shapes]
        if missing:
            raise EpisodeError(f"{path}: camera_names lists {missing} but their images are missing")
    return _order_cameras(shapes, listed), shapes


def episode_path(folder: str | os.PathLike[str], index: int) -> Path:
    """Path of episode ``index`` in ``folder``: ``<folder>/episode_<index>.hdf5``."""
    if int(index) < 0:
        raise EpisodeError(f"episode index must be >= 0, got {index}")
    return Path(folder).expanduser() / episode_file_name(int(index))


def list_episodes(
    folder: str | os.PathLike[str], missing_ok: bool = False
) -> list[tuple[int, Path]]:
    """Episode files ``episode_<k>.hdf5`` in ``folder`` as ``(k, path)``, sorted by ``k``.

    Temporary files of unfinished writes and other names are ignored.

    Raises:
        EpisodeError: ``folder`` does not exist (unless ``missing_ok``) or is not a folder.
    """
    folder = Path(folder).expanduser()
    if not folder.exists():
        if missing_ok:
            return []
        raise EpisodeError(f"data folder not found: {folder}")
    if not folder.is_dir():
        raise EpisodeError(f"{folder} is not a folder")
    found = []
    for path in folder.iterdir():
        match = EPISODE_FILE_RE.match(path.name)
        if match and path.is_file():
            found.append((int(match.group(1)), path))
    return sorted(found)


def iter_episodes(folder: str | os.PathLike[str], load_images: bool = False) -> Iterator[Episode]:
    """Load the episodes of ``folder`` one after the other, in index order."""
    for _, path in list_episodes(folder):
        yield load_episode(path, load_images=load_images)


def resolve_data_dir(root_dir: str | os.PathLike[str], data_dir: str | os.PathLike[str]) -> Path:
    """Dataset folder: ``data_dir`` inside ``root_dir``, unless ``data_dir`` is absolute.

    ``~`` is expanded in both.
    """
    if not str(data_dir).strip():
        raise UserError("data_dir must not be empty")
    data = Path(data_dir).expanduser()
    return data if data.is_absolute() else Path(root_dir).expanduser() / data
