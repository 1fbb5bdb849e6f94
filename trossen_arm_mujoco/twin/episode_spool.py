"""The steps of one episode, kept on disk until it ends, then published as an episode file.

An :class:`EpisodeSpool` keeps a served or teleoperated episode's steps in an append-only
temporary file in the dataset folder (memory stays flat; a process that dies keeps every
whole step), named ``.serve_spool.<pid>-<random>.tmp`` or, with ``anonymous=True``, unnamed.
:meth:`EpisodeSpool.publish` streams the steps through the
:class:`~trossen_arm_mujoco.data.writer.EpisodeWriter` and deletes the spool;
:meth:`EpisodeSpool.discard` deletes it unpublished; :mod:`.spool_recovery` publishes a dead
process's spool.

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
import os
import re
import secrets
import struct
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.twin.frame import Frame

__all__ = [
    "HEADER_LENGTH",
    "MAGIC",
    "NUMERIC",
    "RECORDING_ID_ATTR",
    "EpisodeSpool",
    "SpoolLayout",
    "read_step_images",
    "spool_pid",
    "write_episode",
]

#: First bytes of a spool file (format version 1), then the header's length (uint64 LE).
MAGIC = b"TAMSPOOL1\n"
#: The header's length after ``MAGIC``.
HEADER_LENGTH = struct.Struct("<Q")
#: Numeric parts of a step, in record order.
NUMERIC = ("qpos", "qvel", "action", "reward", "env_state")
#: Attribute of a published episode naming the spool it came from (recovery skips a spool
#: whose episode was published just before its process died).
RECORDING_ID_ATTR = "recording_id"

_SPOOL_RE = re.compile(r"^\.serve_spool\.(?P<pid>[0-9]+)-[0-9a-f]+\.tmp$")


def spool_pid(path: Path) -> int | None:
    """The pid in a serve spool's name (None: not a spool's name)."""
    match = _SPOOL_RE.match(path.name)
    return int(match["pid"]) if match else None


class EpisodeSpool:
    """Steps of one episode until it ends; see the module doc.

    Args:
        folder: the dataset folder (the spool goes there, hidden).
        camera_names, height, width: the frames every step carries.
        anonymous: an unnamed temporary file (no ``path``; teleop), not a named one.
        meta: what a later run needs to publish the episode if this process dies: JSON-able
            values (numpy arrays and scalars are converted), e.g. ``{"attrs": {...},
            "compression": "gzip"}``.
    """

    def __init__(
        self,
        folder: Path,
        camera_names: Sequence[str],
        height: int,
        width: int,
        anonymous: bool = False,
        meta: Mapping[str, Any] | None = None,
    ) -> None:
        self.folder, self.camera_names = Path(folder), list(camera_names)
        self.height, self.width = int(height), int(width)
        self.meta: dict[str, Any] = dict(meta or {})
        self.rows: dict[str, list[Any]] = {k: [] for k in NUMERIC}
        self.path: Path | None = None
        self._fd: int | None = None  # None: no file (anonymous, no cameras) or closed
        self._unnamed: Any = None  # the unnamed temporary file behind ``_fd``
        self._layout: SpoolLayout | None = None  # set by the first step
        self._offset = 0  # where the records begin
        self._open = True
        if anonymous and self.camera_names:
            self._unnamed = tempfile.TemporaryFile(dir=self.folder, prefix=".spool.")
            self._fd = self._unnamed.fileno()
        elif not anonymous:
            path = self.folder / f".serve_spool.{os.getpid()}-{secrets.token_hex(4)}.tmp"
            flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
            self._fd = os.open(path, flags, 0o644)
            self.path = path

    def __len__(self) -> int:
        return len(self.rows["reward"])

    @property
    def rewards(self) -> np.ndarray:
        """Rewards so far, (T,)."""
        return np.asarray(self.rows["reward"], dtype=np.float64)

    @property
    def actions(self) -> np.ndarray:
        """Actions so far, (T, action dim)."""
        return np.asarray(self.rows["action"], dtype=np.float64)

    def append(self, frame: Frame, images: Mapping[str, np.ndarray]) -> None:
        """One step: the frame's state, action and reward, and its camera images."""
        self.append_step(
            frame.qpos, frame.qvel, frame.action, frame.reward, frame.env_state, images
        )

    def append_step(
        self,
        qpos: np.ndarray,
        qvel: np.ndarray,
        action: np.ndarray,
        reward: float,
        env_state: np.ndarray,
        images: Mapping[str, np.ndarray],
    ) -> None:
        """One step: observation (``qpos``, ``qvel``, ``env_state``) before the action,
        the action, the reward after it, and the camera images (all copied, on disk when
        this returns).

        Args:
            qpos: joint positions before the action, (nq,) float (rad; gripper m).
            qvel: joint velocities before the action, (nv,) float (rad/s; m/s).
            action: the action of the step, (n_action,) float (rad; gripper m).
            reward: the task's reward after the action.
            env_state: the object poses before the action, (7 * n_objects,) float (xyz m, quat wxyz,
                world).
            images: camera name -> (H, W, 3) uint8 frame, every camera of the spool.
        """
        if not self._open:
            raise ValueError("the spool was already published or discarded")
        values = {
            "qpos": np.array(qpos, dtype=np.float64).reshape(-1),
            "qvel": np.array(qvel, dtype=np.float64).reshape(-1),
            "action": np.array(action, dtype=np.float64).reshape(-1),
            "reward": np.array([reward], dtype=np.float64),
            "env_state": np.array(env_state, dtype=np.float64).reshape(-1),
        }
        if self._layout is None:
            widths = {k: int(v.size) for k, v in values.items()}
            self._layout = SpoolLayout(widths, self.camera_names, self.height, self.width)
            header = _header(self._layout, self.meta)
            self._write(header)
            self._offset = len(header)
        layout = self._layout
        numbers = np.concatenate([values[k] for k in NUMERIC])
        if numbers.size != layout.numbers:
            raise ValueError(
                f"step {len(self)} has {numbers.size} values, the first had {layout.numbers}"
            )
        frames = []
        for cam in self.camera_names:
            image = np.ascontiguousarray(images[cam], dtype=np.uint8)
            if image.shape != (self.height, self.width, 3):
                raise ValueError(
                    f"step {len(self)}: image '{cam}' is {image.shape}, expected "
                    f"{(self.height, self.width, 3)}"
                )
            frames.append(image)
        self._write(numbers.tobytes())
        for image in frames:
            self._write(memoryview(image).cast("B"))
        for k in NUMERIC:
            self.rows[k].append(float(values[k][0]) if k == "reward" else values[k])

    def _write(self, data: bytes | memoryview) -> None:
        if self._fd is None:  # numbers only, kept in memory
            return
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view) :]

    def _images(self, t: int) -> dict[str, np.ndarray]:
        assert self._layout is not None and self._fd is not None
        return read_step_images(self._fd, self._layout, t, self._offset)

    def publish(self, path: Path, attrs: Mapping[str, Any], compression: str) -> Path:
        """Write the episode to ``path`` through ``EpisodeWriter`` (never overwriting; the
        file appears only complete and read back), then delete the spool. Raises what the
        writer raises: then a named spool is kept (closed; :attr:`path` holds the steps for
        ``spool_recovery.recover_spools``), an anonymous one deleted.

        Args:
            path: the episode file to write (never overwritten).
            attrs: the episode's attributes (as ``EpisodeWriter`` takes them).
            compression: the image compression (``gzip``, ``lzf`` or ``none``).
        """
        if not self._open:
            raise ValueError("the spool was already published or discarded")
        try:
            out = write_episode(
                path,
                self.rows,
                self._images,
                self.camera_names,
                self.height,
                self.width,
                attrs,
                compression,
            )
        except BaseException:
            if self.path is None:
                self.discard()
            else:
                self.close()
            raise
        self.discard()
        return out

    def close(self) -> None:
        """Close the file and keep it (a named spool stays for ``spool_recovery``);
        idempotent, never raises."""
        fd, self._fd, self._open = self._fd, None, False
        if self._unnamed is not None:
            try:
                self._unnamed.close()  # closes ``fd`` too; the unnamed file is gone
            except Exception:
                pass
            self._unnamed = None
        elif fd is not None:
            try:
                os.close(fd)
            except OSError:
                pass

    def discard(self) -> None:
        """Delete the spool (idempotent, never raises)."""
        self.close()
        if self.path is not None:
            try:
                self.path.unlink(missing_ok=True)
            except OSError:
                pass
            self.path = None


@dataclass(frozen=True)
class SpoolLayout:
    """What one record holds: numeric widths (by part of ``NUMERIC``), then each camera's
    frame."""

    widths: Mapping[str, int]
    camera_names: Sequence[str]
    height: int
    width: int

    @property
    def numbers(self) -> int:
        """float64 values of one record."""
        return sum(self.widths[k] for k in NUMERIC)

    @property
    def frame_bytes(self) -> int:
        """Bytes of one camera's frame."""
        return self.height * self.width * 3

    @property
    def record_bytes(self) -> int:
        """Bytes of one record (one step)."""
        return 8 * self.numbers + len(self.camera_names) * self.frame_bytes


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _header(layout: SpoolLayout, meta: Mapping[str, Any]) -> bytes:
    body = json.dumps(
        {
            "widths": dict(layout.widths),
            "camera_names": list(layout.camera_names),
            "height": layout.height,
            "width": layout.width,
            "meta": _jsonable(meta),
        }
    ).encode()
    return MAGIC + HEADER_LENGTH.pack(len(body)) + body


def read_step_images(fd: int, layout: SpoolLayout, t: int, offset: int) -> dict[str, np.ndarray]:
    """Camera frames of step ``t`` (the records start at ``offset``).

    Args:
        fd: the spool's open file descriptor.
        layout: what one record holds.
        t: the step index.
        offset: byte offset of the first record (the header's end).
    """
    start = offset + t * layout.record_bytes + 8 * layout.numbers
    out = {}
    for i, cam in enumerate(layout.camera_names):
        raw = os.pread(fd, layout.frame_bytes, start + i * layout.frame_bytes)
        if len(raw) != layout.frame_bytes:
            raise OSError(f"the spool ends inside step {t}")
        out[cam] = np.frombuffer(raw, dtype=np.uint8).reshape(layout.height, layout.width, 3)
    return out


def write_episode(
    path: Path,
    rows: Mapping[str, Sequence[Any]],
    images: Callable[[int], dict[str, np.ndarray]],
    camera_names: Sequence[str],
    height: int,
    width: int,
    attrs: Mapping[str, Any],
    compression: str,
) -> Path:
    """Publish spooled steps as the episode file ``path`` through ``EpisodeWriter``:
    ``rows`` by part of ``NUMERIC``, ``images(t)`` the frames of step ``t``. Returns the
    file's path.

    Args:
        path: the episode file to write (never overwritten).
        rows: the numeric steps by part of ``NUMERIC`` (qpos, qvel, action, reward, env_state).
        images: ``images(t)``: camera name -> (H, W, 3) uint8 frame of step ``t``.
        camera_names: the cameras, in the file's order.
        height: H of every frame, pixels.
        width: W of every frame, pixels.
        attrs: the episode's attributes.
        compression: the image compression (``gzip``, ``lzf`` or ``none``).
    """
    n = len(rows["reward"])
    env_dim = len(rows["env_state"][0]) if n else 7
    with EpisodeWriter(
        path,
        episode_len=n,
        camera_names=camera_names,
        height=height,
        width=width,
        compression=compression,
        attrs=attrs,
        env_state_dim=env_dim,
        create_folder=False,
    ) as writer:
        for t in range(n):
            writer.append(
                qpos=rows["qpos"][t],
                qvel=rows["qvel"][t],
                action=rows["action"][t],
                reward=rows["reward"][t],
                env_state=rows["env_state"][t],
                images=images(t) if camera_names else {},
            )
    return writer.path
