"""The pose-encoder part of ``train_eval.py`` (``--pose_encoder``, the ``camera_pose`` recipe).

Before training, the exported dataset is derived once (``trossen_arm_mujoco.train.
pose_dataset``): a small encoder learns the cube's pose from the camera's frames, and a copy
of the dataset gets the encoder's estimates as ``observation.environment_state``. Every
training run on that copy observes the joints and those estimates (no image: the encoder is
frozen, so no run pays for an image network); before scoring, each checkpoint gets the
encoder as a step of its preprocessor (``trossen_arm_mujoco.eval.camera_pose_step``), so at
run time it observes the joints and the camera only, as a real kit gives them. With
``--static_frames N`` the record phase also records N three-step episodes (the scene at its
start) whose first frames the encoder trains on besides the episodes' (the insertion's
default: its ``TaskEntry.pose_static_frames``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

#: Offset of the static episodes' recording seed from the episodes' (``--seed``).
STATIC_SEED = 1_000_000
#: The derived dataset, in the work folder beside ``dataset``.
POSE_DATASET = "dataset_pose"
#: ``train.pose_dataset.ENCODER_FILE`` (plain here: the train phase may run where the project
#: is not installed; a test checks they agree).
ENCODER_FILE = "meta/pose_encoder.safetensors"


def pose_dataset(work: Path) -> Path:
    return work / POSE_DATASET


def derived_ready(derived: Path) -> bool:
    """Whether ``derived`` is a whole derived dataset (its info and its encoder)."""
    return (derived / "meta" / "info.json").is_file() and (derived / ENCODER_FILE).is_file()


def encode_job(
    python: str,
    dataset: Path,
    episodes: Path,
    out: Path,
    threads: int,
    seed: int,
    static: Path | None = None,
    augment: bool = False,
) -> list[str]:
    """The command that derives ``out`` from ``dataset`` and its ``episodes`` (and the
    ``static`` episodes' first frames; ``augment``: the encoder's training images changed)."""
    return (
        [
            python,
            "-m",
            "trossen_arm_mujoco.train.pose_dataset",
            str(dataset),
            str(episodes),
            str(out),
            "--threads",
            str(threads),
            "--seed",
            str(seed),
        ]
        + (["--static_episodes", str(static)] if static else [])
        + (["--augment"] if augment else [])
    )


def static_folder(work: Path) -> Path:
    """Where ``--static_frames`` episodes are recorded, beside ``episodes``."""
    return work / "static"


def static_job(cli: list[str], args: Any, folder: Path) -> list[str]:
    """``trossen-mujoco record`` of ``args.static_frames`` 3-step episodes of the task with
    the dataset's camera settings: each starts with the arms at home and the objects where
    the task's sampler puts them, so their first frames show the objects and nothing that
    moves (an arm already reaching for an object would tell the encoder where it is). Their
    seeds are a stream of their own (``args.seed`` + 1,000,000). The episodes end long before
    the task could succeed: the recorder keeps them and exits with status 1."""
    crop = ["--crop", args.crop] if args.crop else []
    return (
        cli
        + [
            "record",
            "--task_name",
            args.task,
            "--data_dir",
            str(folder),
            "--num_episodes",
            str(args.static_frames),
            "--seed",
            str(args.seed + STATIC_SEED),
            "--cam_names",
            args.cam_names,
            "--image_size",
            args.image_size,
            "--episode_len",
            "3",
            "--num_workers",
            "2",
        ]
        + (["--randomize"] if getattr(args, "randomize", False) else [])
        + crop
    )


def inputs_flag(dataset: Path) -> list[str]:
    """``--policy.input_features``: the joints and the estimated poses, no image (LeRobot
    would otherwise give the policy every ``observation.*`` feature, the camera too)."""
    info = json.loads((dataset / "meta" / "info.json").read_text())
    feats = info["features"]
    inputs = {
        "observation.state": {"type": "STATE", "shape": feats["observation.state"]["shape"]},
        "observation.environment_state": {
            "type": "ENV",
            "shape": feats["observation.environment_state"]["shape"],
        },
    }
    return ["--policy.input_features=" + json.dumps(inputs)]


def encoder_report(dataset: Path) -> dict:
    """What ``pose_dataset`` measured (held-out errors in mm, CPU and wall seconds)."""
    from trossen_arm_mujoco.train.pose_dataset import REPORT_FILE

    return json.loads((dataset / REPORT_FILE).read_text())


def encoder_of(dataset: Path) -> tuple[Path, str]:
    """The derived dataset's encoder file and the camera it reads."""
    return dataset / ENCODER_FILE, encoder_report(dataset)["camera"]
