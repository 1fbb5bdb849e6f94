"""The ``encode`` phase of ``trossen-mujoco train`` (``--pose_encoder``, the camera_pose
recipes): the exported dataset derived once into ``dataset_pose``, whose object poses are a
pose encoder's estimates from the camera (``train.pose_dataset``). Every run trains on it;
before scoring, each checkpoint gets the encoder in its preprocessor (``prepare``), so it
observes the joints and the camera only.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import argparse

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.train.jobs import JobSpec, cores, run_jobs
from trossen_arm_mujoco.train.workspace import POSE_DATASET, Workspace

__all__ = ["encode", "encode_job"]


def encode_job(
    python: str, ws: Workspace, threads: int, seed: int, static: bool, augment: bool = False
) -> list[str]:
    """The command deriving ``dataset_pose`` from ``dataset`` and its episodes (and the
    static episodes' first frames; ``augment``: the encoder's training images changed).

    Args:
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        ws: the locked work folder (``train.workspace``).
        threads: CPU threads of the job.
        seed: the encoder's seed.
        static: also train on the static episodes' first frames.
        augment: train on frames with the light, colour and place changed.
    """
    return [
        python,
        "-m",
        "trossen_arm_mujoco.train.pose_dataset",
        str(ws.dataset),
        str(ws.episodes),
        str(ws.pose_dataset),
        "--threads",
        str(threads),
        "--seed",
        str(seed),
        *(["--static_episodes", str(ws.static)] if static else []),
        *(["--augment"] if augment else []),
    ]


def encode(
    ws: Workspace, args: argparse.Namespace, python: str, env: dict[str, str], asked: bool
) -> None:
    """Derive ``dataset_pose`` unless it is whole (``asked``: the phase was named, so a
    whole one is said in a line; the train phase derives it too when missing).

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
        asked: the phase was named (a whole dataset is then said in a line).
    """
    if ws.derived_ready():
        if asked:
            print(f"encode: {ws.pose_dataset} already derived")
        return
    if not ws.exported(ws.dataset) or not ws.episodes.is_dir():
        raise UserError(
            f"no {POSE_DATASET} in {ws.root}, and no {ws.dataset.name}/ and "
            f"{ws.episodes.name}/ to derive it from: run --phase record,export,encode where "
            f"the episodes are (and carry {POSE_DATASET}/ to a train-only machine)"
        )
    command = encode_job(
        python, ws, cores(), args.seed, bool(args.static_frames), augment=args.augment
    )
    took = run_jobs([JobSpec("pose encoder", command, ws.log("encode"))], env)[0]
    ws.summary["encode"] = {**took, "report": ws.encoder_report()}
    ws.save()
