"""The flags of ``trossen-mujoco train``, over the defaults of ``--recipe``, checked before
anything runs (one line each).

Docs: docs/cli/train.md.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from trossen_arm_mujoco.errors import ArgumentParser, UserError
from trossen_arm_mujoco.tasks.registry import DEFAULT_TASK
from trossen_arm_mujoco.train.recipes import (
    CROPPED,
    RECIPES,
    camera_settings_error,
    task_camera_facts,
    task_cameras,
)

__all__ = ["DEFAULT_PHASES", "PHASES", "build_parser", "parse_args", "phases_of"]

PHASES = ("record", "export", "encode", "train", "eval", "wire")
#: Phases run when ``--phase`` is not given (``wire`` needs an idle machine: asked for;
#: ``encode`` does nothing without ``--pose_encoder``).
DEFAULT_PHASES = ("record", "export", "encode", "train", "eval")


def _data_flags(p: argparse.ArgumentParser) -> None:
    """What is recorded and exported."""
    p.add_argument("--task", default=DEFAULT_TASK)
    p.add_argument(
        "--episodes",
        type=int,
        default=200,
        help="scripted episodes to record (200: the amount whose runs met the goal; "
        "docs Benchmarks, 'The whole loop')",
    )
    p.add_argument("--seed", type=int, default=0, help="recording seed")
    p.add_argument(
        "--inject_noise", action="store_true", help="record with the scripted plan's waypoint noise"
    )
    p.add_argument(
        "--randomize",
        action="store_true",
        help="record (and record the static frames) with each episode's scene randomized by "
        "the task's randomization section (record --randomize: lights, table, colours, "
        "friction, masses, damping, camera poses, the arms' start)",
    )
    p.add_argument("--cam_names", default="none")
    p.add_argument("--image_size", default="96x128")
    p.add_argument(
        "--crop",
        default=None,
        metavar="CAMERA:TOP,LEFT,HEIGHT,WIDTH",
        help="record and evaluate this rectangle of the camera's 480x640 frame "
        "(trossen-mujoco record --crop; e.g. cam_high:217,243,150,200, the "
        "transfer cube's spawn region; default: whole frames, or the task's crop for the "
        "camera recipes)",
    )
    p.add_argument("--fps", type=int, default=50, help="export (and eval) rate")


def _run_flags(p: argparse.ArgumentParser) -> None:
    """How many training runs, where and how fast."""
    p.add_argument(
        "--train_seeds",
        type=int,
        default=1,
        help="training runs on the same data, seeds --train_seed, +1, ...",
    )
    p.add_argument("--train_seed", type=int, default=1000, help="first training seed")
    p.add_argument(
        "--train_jobs", type=int, default=1, help="training runs at a time (several fit one GPU)"
    )
    p.add_argument(
        "--train_threads",
        type=int,
        default=0,
        help="CPU threads of each training run (default: the cores shared among the runs "
        "at a time; torch's own default oversubscribes the cores when runs share them)",
    )
    p.add_argument("--num_workers", type=int, default=0, help="lerobot-train's data loaders")
    p.add_argument(
        "--video_backend",
        default="",
        help="lerobot-train's --dataset.video_backend (pyav where torchcodec "
        "has no FFmpeg; default: LeRobot's)",
    )
    p.add_argument("--save_freq", type=int, default=1000, help="checkpoint every N steps")
    p.add_argument("--device", default="cpu")


def _policy_flags(p: argparse.ArgumentParser) -> None:
    """What ACT is and how it learns."""
    p.add_argument("--steps", type=int, default=7000)
    p.add_argument("--batch_size", type=int, default=16)
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument(
        "--lr_schedule",
        choices=["constant", "cosine"],
        default="cosine",
        help="cosine (default): decayed from --lr to --lr_final over --steps; "
        "constant: ACT's preset, whose rate never decays, so the last checkpoint "
        "lands wherever the noise of the updates left it (one run's score moved "
        "between 52 %% and 92 %% from one saved checkpoint to the next)",
    )
    p.add_argument(
        "--lr_final", type=float, default=1e-6, help="the rate at the last step with cosine"
    )
    p.add_argument("--dim_model", type=int, default=256)
    p.add_argument("--dim_feedforward", type=int, default=1024)
    p.add_argument("--n_encoder_layers", type=int, default=4)
    p.add_argument("--n_decoder_layers", type=int, default=1)
    p.add_argument("--chunk_size", type=int, default=50)
    p.add_argument(
        "--n_action_steps",
        type=int,
        default=0,
        help="actions executed per chunk (default: --chunk_size)",
    )
    p.add_argument(
        "--temporal_ensemble_coeff",
        type=float,
        default=0.01,
        help="ACT's temporal ensembling, in the checkpoint's config (one action per inference: "
        "the averaged actions stay within the arms' speed limits; 0: off, --n_action_steps "
        "actions per chunk; default 0.01)",
    )
    p.add_argument("--use_vae", default="false")
    p.add_argument(
        "--normalize_env",
        default="MEAN_STD",
        help="normalization of observation.environment_state (ACT's default mapping leaves "
        "ENV features raw, in metres, and the policy then learns to ignore the cube: "
        "MEAN_STD fixes that; IDENTITY is LeRobot's default)",
    )
    p.add_argument(
        "--no_env_state",
        action="store_true",
        help="train on the state and the cameras only: the policy does not see "
        "observation.environment_state (the object poses), so it must find the cube in the "
        "images (the camera recipe)",
    )
    p.add_argument(
        "--train_arg",
        action="append",
        default=[],
        help="one more lerobot-train flag, e.g. --train_arg=--policy.dropout=0.1 (repeatable)",
    )


def _pose_flags(p: argparse.ArgumentParser) -> None:
    """The pose encoder of the camera_pose recipes."""
    p.add_argument(
        "--pose_encoder",
        action="store_true",
        help="train a small encoder once to find the cube in the camera and train every run "
        "on its estimates (the camera_pose recipe)",
    )
    p.add_argument(
        "--static_frames",
        type=int,
        default=None,
        help="with --pose_encoder: record this many 3-step episodes (the scene at "
        "its start, objects sampled) whose first frames the encoder also trains on "
        "(default: the task's TaskEntry.pose_static_frames: 1000 for the "
        "insertion, 0 for the transfer)",
    )
    p.add_argument(
        "--augment",
        action="store_true",
        help="with --pose_encoder: train the encoder on frames with the light, the camera's "
        "exposure and white balance changed and the image shifted by up to 2 pixels",
    )


def _eval_flags(p: argparse.ArgumentParser) -> None:
    """How each checkpoint is scored."""
    p.add_argument("--eval_episodes", type=int, default=50)
    p.add_argument("--eval_workers", type=int, default=2)
    p.add_argument("--eval_seed", type=int, default=0)
    p.add_argument(
        "--eval_randomize",
        default="nominal",
        choices=("nominal", "train", "hard"),
        help="the evaluation level (eval --randomize LEVEL; default nominal: the model's "
        "scene); benchmarks/robustness.py scores a checkpoint at every level",
    )
    p.add_argument(
        "--controller_checks",
        choices=("both", "on", "off"),
        default="both",
        help="eval's --controller_checks: both (default: the score with the arm "
        "controller's checks and, beside it, without), on, or off",
    )
    p.add_argument(
        "--eval_episode_length",
        type=int,
        default=0,
        help="eval episode length in steps (default: the task's)",
    )


def build_parser() -> argparse.ArgumentParser:
    """Every flag of ``trossen-mujoco train``."""
    p = ArgumentParser(
        prog="trossen-mujoco train",
        description="Record scripted episodes, export them, train LeRobot's ACT over several "
        "seeds and score each checkpoint in the sim; a rerun resumes.",
    )
    p.add_argument("--work_dir", default="train_eval_out")
    p.add_argument(
        "--recipe",
        choices=tuple(RECIPES),
        default="state",
        help="flag defaults: state (the joints and the object poses, 50 fps), camera_pose "
        "(the joints and cam_high only, as a real kit gives, 30 fps, a pose encoder reading "
        "the camera), camera_pose_robust (camera_pose on randomized scenes, the encoder on "
        "augmented frames) or camera (end to end); flags given still win (default: state)",
    )
    p.add_argument(
        "--phase",
        default=",".join(DEFAULT_PHASES),
        help="comma list of phases to run, any subset of record,export,encode,"
        "train,eval,wire (default: record,export,encode,train,eval)",
    )
    for add in (_data_flags, _run_flags, _policy_flags, _pose_flags, _eval_flags):
        add(p)
    return p


def _fail(problem: str | None) -> None:
    if problem:
        raise UserError(problem)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The flags, over the defaults of ``--recipe``, the task's crop and static frames
    filled in; camera settings checked (a UserError, one line)."""
    parser = build_parser()
    recipe = parser.parse_known_args(argv)[0].recipe
    parser.set_defaults(**RECIPES[recipe])
    args = parser.parse_args(argv)
    if recipe in CROPPED or args.pose_encoder:  # the task's own settings (its TaskEntry)
        crop, static, problem = task_camera_facts(recipe, args.task)
        if args.crop is None and recipe in CROPPED:
            _fail(problem)
            args.crop = crop
        if args.static_frames is None and args.pose_encoder:
            args.static_frames = static
    if args.static_frames is not None and args.static_frames < 0:
        _fail(f"--static_frames {args.static_frames}: give a count >= 0 (0: none)")
    if args.static_frames and not args.pose_encoder:
        _fail(
            "--static_frames trains the pose encoder: use it with --recipe camera_pose (or "
            "--pose_encoder), or leave it out"
        )
    args.static_frames = args.static_frames or 0
    if args.augment and not args.pose_encoder:
        _fail(
            "--augment changes the pose encoder's training frames: use it with --recipe "
            "camera_pose (or --pose_encoder), or leave it out"
        )
    cameras = task_cameras(args.task)
    _fail(
        camera_settings_error(
            args.cam_names, args.image_size, args.crop, args.pose_encoder, cameras
        )
    )
    phases_of(args)
    if args.train_seeds < 1 or args.train_jobs < 1:
        _fail("--train_seeds and --train_jobs must be at least 1")
    return args


def phases_of(args: argparse.Namespace) -> list[str]:
    """The phases ``--phase`` names, in the order given; a UserError for an unknown one."""
    phases = [x.strip() for x in args.phase.split(",") if x.strip()]
    unknown = sorted(set(phases) - set(PHASES))
    if unknown or not phases:
        _fail(f"--phase {args.phase!r}: unknown {unknown}; choose from {','.join(PHASES)}")
    return phases
