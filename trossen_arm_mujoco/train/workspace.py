"""The work folder of ``trossen-mujoco train``: its layout, its lock and its summary.

Layout (every phase reads what the earlier ones left)::

    episodes/            record: the scripted episodes (HDF5)
    static/              record, --static_frames: the 3-step episodes of the pose encoder
    dataset/             export: the LeRobot dataset
    dataset_pose/        encode: the dataset with the encoder's estimates, and the encoder
    train/seed_N/        train: lerobot-train's output (checkpoints/last/pretrained_model)
    eval/seed_N/         eval: trossen-mujoco eval's eval_info.json
    wire/seed_N/         wire: the same through the served kit
    summary.json         what every phase measured, merged across calls
    train.lock           held (flock) by the run working here; it holds that run's pid
    <phase>.log          each child process's output

Plain Python: the train phase may run where the simulator is not installed.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import check_writable_dir, write_text
from trossen_arm_mujoco.train.pose_files import ENCODER_FILE, REPORT_FILE

__all__ = ["LOCK_FILE", "POSE_DATASET", "Workspace"]

#: The derived dataset of the pose encoder, beside ``dataset``.
POSE_DATASET = "dataset_pose"
#: The lock file of a work folder.
LOCK_FILE = "train.lock"
#: What the flag naming the folder is called, in messages.
FLAG = "--work_dir"


@dataclass
class Workspace:
    """One work folder (:meth:`open` it) and its summary, loaded and merged into."""

    root: Path
    summary: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def open(cls, path: str | os.PathLike[str]) -> Workspace:
        """The work folder at ``path``, created when missing; a UserError (one line) when it
        cannot be written (a file, read-only, permissions)."""
        root = check_writable_dir(Path(path).expanduser().resolve(), FLAG)
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:  # check_writable_dir passed: a race, said in one line anyway
            raise UserError(f"{FLAG} {root}: cannot create it ({exc.strerror or exc})") from None
        return cls(root)

    # -- the layout ---------------------------------------------------------------------------

    @property
    def episodes(self) -> Path:
        """The recorded episodes."""
        return self.root / "episodes"

    @property
    def static(self) -> Path:
        """Where ``--static_frames`` episodes are recorded."""
        return self.root / "static"

    @property
    def dataset(self) -> Path:
        """The exported LeRobot dataset."""
        return self.root / "dataset"

    @property
    def pose_dataset(self) -> Path:
        """The dataset derived by the pose encoder (``encode``)."""
        return self.root / POSE_DATASET

    def training_dataset(self, pose: bool) -> Path:
        """The dataset every run trains on (and every score reads): the derived one with
        the pose encoder."""
        return self.pose_dataset if pose else self.dataset

    def train_dir(self, seed: int) -> Path:
        """lerobot-train's output folder for the run of ``seed``."""
        return self.root / "train" / f"seed_{seed}"

    def checkpoint(self, seed: int) -> Path:
        """The last checkpoint of the run of ``seed``."""
        return self.train_dir(seed) / "checkpoints" / "last" / "pretrained_model"

    def eval_dir(self, seed: int, backend: str) -> Path:
        """Where the run of ``seed`` is scored: ``eval/`` in the sim, ``wire/`` served."""
        return self.root / ("wire" if backend == "wire" else "eval") / f"seed_{seed}"

    def log(self, name: str) -> Path:
        """The log of the child process ``name``."""
        return self.root / f"{name}.log"

    @property
    def summary_path(self) -> Path:
        """``summary.json``: what every phase measured, merged across calls."""
        return self.root / "summary.json"

    @property
    def lock_path(self) -> Path:
        """The lock file (:data:`LOCK_FILE`)."""
        return self.root / LOCK_FILE

    # -- facts about what is there ------------------------------------------------------------

    @staticmethod
    def exported(dataset: Path) -> bool:
        """Whether ``dataset`` is a whole export (its info.json written last)."""
        return (dataset / "meta" / "info.json").is_file()

    def derived_ready(self) -> bool:
        """Whether the derived dataset is whole (its info and its encoder)."""
        return self.exported(self.pose_dataset) and (self.pose_dataset / ENCODER_FILE).is_file()

    def encoder_report(self) -> dict[str, Any]:
        """What the pose encoder measured (held-out errors in mm, CPU seconds, camera)."""
        return json.loads((self.pose_dataset / REPORT_FILE).read_text(encoding="utf-8"))

    def encoder(self) -> tuple[Path, str]:
        """The derived dataset's encoder file and the camera it reads."""
        return self.pose_dataset / ENCODER_FILE, self.encoder_report()["camera"]

    # -- the lock -----------------------------------------------------------------------------

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the folder's lock for the block (``flock`` on :data:`LOCK_FILE`, released by
        the OS even when the process is killed); a UserError naming the process that holds it
        when another run works here."""
        try:
            import fcntl
        except ImportError:  # no flock on this platform: unlocked
            yield
            return
        fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
                who = f"process {holder}" if holder.isdigit() else "another process"
                raise UserError(
                    f"{FLAG} {self.root} is in use by {who} (another trossen-mujoco train); "
                    f"wait for it to end, or choose another {FLAG}"
                ) from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
            yield
        finally:
            os.close(fd)  # releases the lock

    # -- the summary --------------------------------------------------------------------------

    def load_summary(self) -> dict[str, Any]:
        """The summary earlier calls left (merged into, never replaced); a UserError when it
        is not one."""
        path = self.summary_path
        if not path.exists():
            self.summary = {}
            return self.summary
        try:
            summary = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:  # truncated, not UTF-8, unreadable
            why = exc.strerror if isinstance(exc, OSError) else " ".join(str(exc).split())
            raise UserError(
                f"{path} cannot be read as JSON ({why}); repair it, or move it away to start "
                "a new summary"
            ) from None
        ok = isinstance(summary, dict)
        kept = (summary.get("settings", {}), summary.get("runs", {})) if ok else ({}, {})
        ok = ok and all(isinstance(part, dict) for part in kept)
        if not ok or not all(isinstance(run, dict) for run in kept[1].values()):
            raise UserError(
                f"{path} is not a summary of trossen-mujoco train (a JSON object whose "
                "'settings' and 'runs' are objects); move it away to start anew"
            )
        self.summary = summary
        return summary

    @property
    def runs(self) -> dict[str, dict[str, Any]]:
        """The summary's runs, by training seed (as a string)."""
        return self.summary.setdefault("runs", {})

    def save(self) -> None:
        """Write the summary (atomically)."""
        write_text(self.summary_path, json.dumps(self.summary, indent=2) + "\n")
