r"""Export recorded episodes to another dataset format (also ``trossen-mujoco export``).

    python trossen_arm_mujoco/scripts/export_dataset.py --format lerobot \
        --data_dir sim_transfer_cube --output ~/datasets/transfer_cube --repo_id me/transfer_cube

``--format lerobot`` writes a LeRobot v3.0 dataset (``trossen_arm_mujoco.export``) that
``LeRobotDataset(repo_id, root=output)`` loads; it needs the ``lerobot`` extra (pyarrow,
PyAV), not LeRobot itself. By default it is what ``lerobot-record`` writes with Trossen's
LeRobot plugin, in the recording's layout (``kit14``, ``mobileai`` or ``widowxai``; or
``--layout vendor16``), resampled to ``--fps N``; ``--sim_features`` adds the simulation's
features.

Docs: docs/cli/export.md, docs/datasets.md.
"""

from __future__ import annotations

__all__ = ["FORMATS", "build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import sys
from collections.abc import Sequence

from trossen_arm_mujoco.data.reader import resolve_data_dir
from trossen_arm_mujoco.errors import ArgumentParser, UserError, run_cli
from trossen_arm_mujoco.robot.layout import EXPORT_LAYOUTS
from trossen_arm_mujoco.scripts.common_options import DEFAULT_TASK, add_data_dir, add_root_dir

FORMATS = ("lerobot",)


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    p = ArgumentParser(
        prog="trossen-mujoco export",
        description="Export recorded HDF5 episodes as a LeRobot v3.0 dataset (parquet + mp4).",
    )
    p.add_argument(
        "--format", default="lerobot", choices=FORMATS, help="dataset format (default: lerobot)"
    )
    add_data_dir(p, "episode folder", example=DEFAULT_TASK)
    add_root_dir(p)
    p.add_argument(
        "--output",
        required=True,
        help="dataset folder to create (relative to the current folder unless absolute); "
        "must be missing or empty",
    )
    p.add_argument(
        "--repo_id",
        required=True,
        help="dataset name <owner>/<name>, what LeRobotDataset(repo_id, root=...) is given",
    )
    p.add_argument(
        "--task",
        default=None,
        help="task description for every episode (default: the task registry's description "
        "of each episode's task; required for vendor recordings)",
    )
    p.add_argument(
        "--layout",
        default=None,
        choices=tuple(EXPORT_LAYOUTS),
        help="joint layout of state and action: kit14 = the real kit's 14 values "
        "(left_joint_0.pos .. left_left_carriage_joint.pos, then right_; Trossen's LeRobot "
        "plugin, bi_widowxai_follower_robot), vendor16 = the HDF5 files' 16, mobileai = the "
        "Mobile AI's 14 arm values then x.vel, theta.vel (mobileai_robot), widowxai = one "
        "arm's 7 (widowxai_follower_robot) (default: the one that fits the recordings: "
        "mobileai for Mobile AI recordings, widowxai for a single arm's, else kit14)",
    )
    p.add_argument(
        "--fps",
        default=None,
        metavar="N",
        help="frames per second to write, a whole number up to the recording rate; lower "
        "rates are resampled (default: 30, the plugin's loop rate)",
    )
    p.add_argument(
        "--sim_features",
        action="store_true",
        help="add the simulation's features, which no real robot records: "
        "observation.velocity (joint velocities), observation.environment_state (object "
        "poses), next.reward, next.success (default: only what lerobot-record writes)",
    )
    p.add_argument(
        "--include_velocity",
        action="store_true",
        help="add each joint's velocity to observation.state as Trossen's LeRobot plugin "
        "names it (left_joint_0.vel .. after each arm's positions; rad/s, m/s; the recorded "
        "qvel)",
    )
    p.add_argument(
        "--include_effort",
        action="store_true",
        help="add each joint's effort to observation.state as the plugin names it "
        "(left_joint_0.eff ..; Nm, N): the actuator force at the recorded state, derived "
        "with MuJoCo's actuator model (gravity compensation included)",
    )
    p.add_argument(
        "--include_external_effort",
        action="store_true",
        help="add each joint's external effort to observation.state as the plugin names it "
        "(left_joint_0.ext_eff ..; Nm, N): the force the arms' own model does not explain "
        "(contacts with objects, the table, the other arm), derived with MuJoCo; 0 in free "
        "motion",
    )
    p.add_argument(
        "--base_action",
        default=None,
        choices=("measured", "commanded"),
        help="the Mobile AI's base part of action (x.vel, theta.vel): measured = the base's "
        "measured velocity of the frame, as the plugin records it (default), commanded = "
        "the recorded velocity command",
    )
    p.add_argument(
        "--vcodec",
        default="libsvtav1",
        choices=("libsvtav1", "h264"),
        help="video codec (default: libsvtav1 = AV1, as LeRobot)",
    )
    p.add_argument(
        "--pix_fmt",
        default="yuv420p",
        choices=("yuv420p", "yuv444p"),
        help="video pixel format; yuv444p keeps full colour resolution (h264 only; "
        "default: yuv420p)",
    )
    p.add_argument(
        "--crf",
        type=int,
        default=None,
        help="video quality, lower is better and larger (default: 30 for libsvtav1, 23 for h264)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the LeRobot dataset already in --output (once the new one is complete)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Export ``--data_dir``; returns the exit status."""
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.export import VideoSettings, export_lerobot
    from trossen_arm_mujoco.export.lerobot_format import ROBOT_TYPES

    data_dir = resolve_data_dir(args.root_dir, args.data_dir)
    if not data_dir.is_dir():
        raise UserError(
            f"data folder not found: {data_dir} (--root_dir {args.root_dir}, --data_dir "
            f"{args.data_dir}); record episodes first or fix the flags"
        )
    if args.task is not None and not args.task.strip():
        raise UserError("--task must not be empty")
    video = VideoSettings(codec=args.vcodec, pix_fmt=args.pix_fmt, crf=args.crf)
    summary = export_lerobot(
        data_dir,
        args.output,
        args.repo_id,
        task=args.task,
        video=video,
        overwrite=args.overwrite,
        layout=args.layout,
        fps=args.fps,
        include_velocity=args.include_velocity,
        include_effort=args.include_effort,
        include_external_effort=args.include_external_effort,
        sim_features=args.sim_features,
        base_action=args.base_action,
    )
    rate = summary.frames / max(summary.seconds, 1e-9)
    cams = ", ".join(summary.cameras) or "none"
    resampled = ""
    if summary.fps != summary.source_fps:
        resampled = f" (resampled from {summary.source_fps} fps)"
    if summary.state_extras:
        added = ", ".join(f"<joint>.{e}" for e in summary.state_extras)
        resampled += f", the state with {added}"
    if summary.sim_features:
        resampled += ", with the sim's features"
    if summary.base_action:
        resampled += f", {summary.base_action} base action"
    print(
        f"exported {summary.episodes} episode(s), {summary.frames} frames at {summary.fps} fps"
        f"{resampled} (cameras: {cams}), layout {summary.layout} (robot_type "
        f"{ROBOT_TYPES[summary.layout]}), to {summary.output} in "
        f"{summary.seconds:.1f} s ({rate:.0f} frames/s)"
    )
    print(f"load it with: LeRobotDataset('{args.repo_id}', root='{summary.output.resolve()}')")
    return 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
