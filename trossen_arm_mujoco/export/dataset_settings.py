"""What a dataset was made with, carried by the dataset and by every checkpoint trained on it.

``trossen-mujoco export`` writes :class:`DatasetSettings` (task, ``fps``, joint layout,
cameras, image size, crops) into ``meta/info.json`` under :data:`INFO_KEY`. A checkpoint
finds them (:func:`checkpoint_settings`) in its own folder first (:data:`CHECKPOINT_FILE`,
:func:`write_checkpoint_settings`), else through the ``train_config.json`` saved beside the
weights (its ``dataset.root``'s ``meta/info.json``). Readers take their defaults from them;
:func:`reconcile` refuses a flag that contradicts them and accepts one that repeats them.

Docs: docs/datasets.md (the LeRobot export), docs/train-eval.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import atomic_path
from trossen_arm_mujoco.sim.camera_settings import CameraSettings

__all__ = [
    "CHECKPOINT_FILE",
    "INFO_KEY",
    "DatasetSettings",
    "checkpoint_settings",
    "read_dataset_settings",
    "reconcile",
    "write_checkpoint_settings",
]

#: Key of the settings in a dataset's ``meta/info.json``.
INFO_KEY = "trossen_arm_mujoco"
#: The settings file in a checkpoint folder (beside ``config.json``).
CHECKPOINT_FILE = "trossen_settings.json"


@dataclass(frozen=True)
class DatasetSettings:
    """What the episodes of a dataset were recorded and exported with.

    Attributes:
        fps: frames per second of the dataset (the policy's rate).
        layout: joint layout of state and action (``kit14``, ``vendor16``, ``mobileai``,
            ``widowxai``).
        cameras: the cameras in recording order (none: state only), the (H, W) of their
            images and the rectangle of its 480x640 frame each cropped camera shows.
        task: the registered task the episodes are of (None: not one of ours).
        state_extras: per-joint values ``observation.state`` has besides the positions:
            ``"vel"``, ``"eff"``, ``"ext_eff"`` (export ``--include_velocity`` /
            ``--include_effort`` / ``--include_external_effort``).
        sim_features: the dataset has the simulation's features (export ``--sim_features``:
            ``observation.velocity``, ``observation.environment_state``, ``next.reward``,
            ``next.success``); settings written before the flag existed read as True (every
            export had them).
        base_action: the Mobile AI's base action, ``measured`` or ``commanded`` (export
            ``--base_action``); None for robots without a base and for settings written
            before the flag (their base action was the command).
    """

    fps: int
    layout: str
    cameras: CameraSettings = field(default_factory=CameraSettings)
    task: str | None = None
    state_extras: tuple[str, ...] = ()
    sim_features: bool = True
    base_action: str | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready form (the cameras as ``CameraSettings.to_json``: ``cam_names``,
        ``image_size``, ``crops`` as their ``--crop`` texts)."""
        return {
            "fps": int(self.fps),
            "layout": self.layout,
            **self.cameras.to_json(),
            "task": self.task,
            "state_extras": list(self.state_extras),
            "sim_features": bool(self.sim_features),
            "base_action": self.base_action,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any], where: str) -> DatasetSettings:
        """Parse :meth:`to_json`'s form; a one-line UserError naming ``where`` if it is not."""
        cameras = CameraSettings.from_json(data, where)  # its own one-line error
        try:
            settings = cls(
                fps=int(data["fps"]),
                layout=str(data["layout"]),
                cameras=cameras,
                task=str(data["task"]) if data.get("task") else None,
                state_extras=tuple(str(e) for e in data.get("state_extras") or ()),
                sim_features=bool(data.get("sim_features", True)),
                base_action=str(data["base_action"]) if data.get("base_action") else None,
            )
        except (KeyError, TypeError, ValueError, IndexError, OverflowError, UserError) as exc:
            raise UserError(
                f"{where}: unreadable dataset settings ({exc}); export the "
                "dataset again with trossen-mujoco export"
            ) from None
        if settings.fps <= 0:
            raise UserError(f"{where}: dataset settings with fps {settings.fps}")
        return settings


def read_dataset_settings(root: str | Path) -> DatasetSettings | None:
    """The settings a dataset folder's ``meta/info.json`` carries; None when it has none
    (a dataset exported before they were written, or not by this package)."""
    path = Path(root).expanduser() / "meta" / "info.json"
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: cannot read it ({exc})") from None
    data = info.get(INFO_KEY) if isinstance(info, dict) else None
    return DatasetSettings.from_json(data, str(path)) if isinstance(data, dict) else None


def write_checkpoint_settings(folder: str | Path, settings: DatasetSettings) -> Path:
    """Write ``settings`` into a checkpoint folder (atomically) as :data:`CHECKPOINT_FILE`."""
    path = Path(folder) / CHECKPOINT_FILE
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(settings.to_json(), indent=2) + "\n", encoding="utf-8")
    return path


def checkpoint_settings(folder: str | Path) -> tuple[DatasetSettings | None, str]:
    """The settings of the checkpoint in ``folder`` (the one holding ``config.json``) and
    where they came from: its :data:`CHECKPOINT_FILE`, else its ``train_config.json``'s
    dataset; ``(None, why)`` when neither says."""
    folder = Path(folder)
    own = folder / CHECKPOINT_FILE
    if own.is_file():
        try:
            data = json.loads(own.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise UserError(f"{own}: cannot read it ({exc})") from None
        if not isinstance(data, dict):
            raise UserError(f"{own}: not a settings object; delete it or train again")
        return DatasetSettings.from_json(data, str(own)), str(own)
    train = folder / "train_config.json"
    try:
        config = json.loads(train.read_text(encoding="utf-8"))
        root = (config.get("dataset") or {}).get("root")
    except (OSError, ValueError, AttributeError):
        return None, f"no {CHECKPOINT_FILE} and no readable train_config.json in {folder}"
    if not root:
        return None, f"{train} names no dataset root"
    settings = read_dataset_settings(root)
    if settings is None:
        return None, f"its dataset {root} carries no settings (missing, or exported before them)"
    return settings, f"{Path(root).expanduser() / 'meta' / 'info.json'}"


def reconcile(
    settings: DatasetSettings | None, source: str, flags: Mapping[str, Any]
) -> dict[str, Any]:
    """Check command-line ``flags`` against a dataset's ``settings``.

    Args:
        settings: what the dataset or checkpoint was made with; None: no settings (every
            flag's own value is returned).
        source: where the settings came from (a path), named in the error.
        flags: flag name -> value given (None when not given). Names: ``fps``, ``layout``,
            ``task`` and the camera flags as ``sim.camera_settings.camera_flags`` parses
            them: ``cam_names`` (tuple), ``image_size`` ((H, W) pixels), ``crops`` (tuple
            of ``CameraCrop``).

    Returns:
        The settings' value for every flag (the flag's own where there are no settings).

    Raises:
        UserError: a flag that contradicts the settings (one line naming the flag, the
            value the checkpoint was trained with and ``source``).
    """
    if settings is None:
        return dict(flags)
    cams = settings.cameras
    known = {
        "fps": settings.fps,
        "layout": settings.layout,
        "cam_names": cams.names,
        "image_size": cams.size if cams.names else None,  # no size without a camera
        "crops": cams.crops,
        "task": settings.task,
    }
    out: dict[str, Any] = {}
    for name, given in flags.items():
        want = known.get(name)
        if given is None or want is None:
            out[name] = want if given is None else given
            continue
        same = (
            math.isclose(float(given), float(want))
            if name == "fps"
            else tuple(given) == tuple(want)
            if isinstance(want, tuple)
            else given == want
        )
        if not same:
            raise UserError(
                f"--{_FLAG.get(name, name)} {_show(name, given)} contradicts the checkpoint, "
                f"trained with {_show(name, want)} ({source}); leave the flag out or give the "
                "same value"
            )
        out[name] = want
    return out


_FLAG = {"crops": "crop", "task": "task_name"}


def _show(name: str, value: Any) -> str:
    if name == "image_size":
        return "x".join(str(v) for v in value)
    if name == "crops":
        return ";".join(c.text() for c in value) if value else "none"
    if isinstance(value, tuple):
        return ",".join(map(str, value)) if value else "none"
    return f"{value:g}" if isinstance(value, float) else str(value)
