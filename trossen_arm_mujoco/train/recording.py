"""The data phases of ``trossen-mujoco train``: ``record`` (the scripted episodes, and the
pose encoder's static frames) and ``export`` (the LeRobot dataset, with the sim's features).
A phase whose output is already whole is skipped with a line.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import argparse

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.train.jobs import JobSpec, cli_command, run_jobs
from trossen_arm_mujoco.train.workspace import Workspace

__all__ = ["STATIC_SEED", "export", "record", "static_job"]

#: Offset of the static episodes' recording seed from the episodes' (``--seed``).
STATIC_SEED = 1_000_000


def _camera_flags(args: argparse.Namespace) -> list[str]:
    return [
        "--cam_names",
        args.cam_names,
        "--image_size",
        args.image_size,
        *(["--randomize"] if getattr(args, "randomize", False) else []),
        *(["--crop", args.crop] if args.crop else []),
    ]


def static_job(cli: list[str], args: argparse.Namespace, ws: Workspace) -> list[str]:
    """``trossen-mujoco record`` of ``args.static_frames`` 3-step episodes of the task with
    the dataset's camera settings: each starts with the arms at home and the objects where
    the task's sampler puts them, so their first frames show the objects and nothing that
    moves. Their seeds are a stream of their own (``--seed`` + :data:`STATIC_SEED`). The
    episodes end long before the task could succeed: the recorder keeps them and exits 1.

    Args:
        cli: the command that runs ``trossen-mujoco`` (the Python and its module).
        args: the parsed flags of ``trossen-mujoco train``.
        ws: the locked work folder (``train.workspace``).
    """
    return [
        *cli,
        "record",
        "--task_name",
        args.task,
        "--data_dir",
        str(ws.static),
        "--num_episodes",
        str(args.static_frames),
        "--seed",
        str(args.seed + STATIC_SEED),
        "--episode_len",
        "3",
        "--num_workers",
        "2",
        *_camera_flags(args),
    ]


def record(ws: Workspace, args: argparse.Namespace, python: str, env: dict[str, str]) -> None:
    """Record ``--episodes`` scripted episodes (and the static frames), unless there.

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
    """
    cli = cli_command(python)
    if (ws.episodes / f"episode_{args.episodes - 1}.hdf5").exists():
        print(f"record: {ws.episodes} already holds {args.episodes} episodes")
    else:
        command = [
            *cli,
            "record",
            "--task_name",
            args.task,
            "--data_dir",
            str(ws.episodes),
            "--num_episodes",
            str(args.episodes),
            "--seed",
            str(args.seed),
            "--num_workers",
            "2",
            "--skip_failed",
            *(["--inject_noise"] if args.inject_noise else []),
            *_camera_flags(args),
        ]
        ws.summary["record"] = run_jobs([JobSpec("record", command, ws.log("record"))], env)[0]
        ws.save()
    last_static = ws.static / f"episode_{args.static_frames - 1}.hdf5"
    if args.static_frames and not last_static.exists():
        spec = JobSpec(
            "record static frames", static_job(cli, args, ws), ws.log("static"), ok=(0, 1)
        )
        ws.summary["record_static"] = run_jobs([spec], env)[0]
        if not last_static.exists():
            raise UserError(
                f"record static frames wrote fewer than {args.static_frames} episodes in "
                f"{ws.static}; see {ws.log('static')}"
            )
        ws.save()


def export(ws: Workspace, args: argparse.Namespace, python: str, env: dict[str, str]) -> None:
    """Export the episodes as a LeRobot dataset with the sim's features, unless done.

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
    """
    if ws.exported(ws.dataset):
        print(f"export: {ws.dataset} already exported")
        return
    command = [
        *cli_command(python),
        "export",
        "--data_dir",
        str(ws.episodes),
        "--output",
        str(ws.dataset),
        "--repo_id",
        "local/sim_dataset",
        "--fps",
        str(args.fps),
        "--sim_features",  # the state recipe observes the object poses
        "--vcodec",
        "h264",
    ]
    ws.summary["export"] = run_jobs([JobSpec("export", command, ws.log("export"))], env)[0]
    ws.save()
