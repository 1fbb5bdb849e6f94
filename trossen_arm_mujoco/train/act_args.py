"""The ``lerobot-train`` command line of ``trossen-mujoco train``: ACT with the settings of
its flags, the rate decayed with ``--lr_schedule cosine``, and the policy's inputs (every
``observation.*`` feature of the dataset, less the object poses with ``--no_env_state``; the
joints and the estimated poses only with ``--pose_encoder``).

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.lerobot_keys import ENV_STATE_KEY, IMAGE_KEY_PREFIX, STATE_KEY

__all__ = ["input_features", "train_args"]


def _features(dataset: Path) -> dict:
    return json.loads((dataset / "meta" / "info.json").read_text(encoding="utf-8"))["features"]


def input_features(args: argparse.Namespace, dataset: Path) -> list[str]:
    """``--policy.input_features`` when the policy must not see every ``observation.*``
    feature of the dataset (LeRobot's default): the joints and the estimated poses with
    ``--pose_encoder``, the joints and the cameras with ``--no_env_state``; else none."""
    if args.pose_encoder:
        feats = _features(dataset)
        inputs = {
            STATE_KEY: {"type": "STATE", "shape": feats[STATE_KEY]["shape"]},
            ENV_STATE_KEY: {"type": "ENV", "shape": feats[ENV_STATE_KEY]["shape"]},
        }
    elif args.no_env_state:
        inputs = {}
        for key, ft in _features(dataset).items():
            if key == STATE_KEY:
                inputs[key] = {"type": "STATE", "shape": ft["shape"]}
            elif key.startswith(IMAGE_KEY_PREFIX):
                h, w, c = ft["shape"]  # LeRobot stores video features (H, W, C); policies: CHW
                inputs[key] = {"type": "VISUAL", "shape": [c, h, w]}
        if not any(k.startswith(IMAGE_KEY_PREFIX) for k in inputs):
            raise UserError("--no_env_state needs a camera: pass --cam_names (e.g. cam_high)")
    else:
        return []
    return ["--policy.input_features=" + json.dumps(inputs)]


def _schedule(args: argparse.Namespace) -> list[str]:
    """ACT's own optimizer settings with the rate decayed to ``--lr_final`` (cosine)."""
    if args.lr_schedule != "cosine":
        return []
    return [
        "--use_policy_training_preset=false",
        "--optimizer.type=adamw",
        f"--optimizer.lr={args.lr}",
        "--optimizer.weight_decay=0.0001",
        "--optimizer.grad_clip_norm=10",
        "--scheduler.type=cosine_decay_with_warmup",
        "--scheduler.num_warmup_steps=0",
        f"--scheduler.num_decay_steps={args.steps}",
        f"--scheduler.peak_lr={args.lr}",
        f"--scheduler.decay_lr={args.lr_final}",
    ]


def train_args(
    args: argparse.Namespace, python: str, dataset: Path, out: Path, seed: int
) -> list[str]:
    """``lerobot-train`` run by ``python`` on ``dataset`` into ``out`` with ``seed``.

    Args:
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        dataset: the LeRobot dataset folder to train on.
        out: ``lerobot-train``'s output folder.
        seed: the training seed.
    """
    n_action = args.n_action_steps or args.chunk_size
    extra = []
    if args.temporal_ensemble_coeff:
        extra = [f"--policy.temporal_ensemble_coeff={args.temporal_ensemble_coeff}"]
        n_action = 1
    if args.video_backend:
        extra.append(f"--dataset.video_backend={args.video_backend}")
    mapping = {"VISUAL": "MEAN_STD", "STATE": "MEAN_STD", "ACTION": "MEAN_STD"}
    return [
        python,
        "-m",
        "lerobot.scripts.lerobot_train",
        "--dataset.repo_id=local/sim_dataset",
        f"--dataset.root={dataset}",
        "--policy.type=act",
        f"--policy.device={args.device}",
        "--policy.push_to_hub=false",
        "--policy.pretrained_backbone_weights=null",
        f"--policy.use_vae={args.use_vae}",
        f"--policy.dim_model={args.dim_model}",
        f"--policy.chunk_size={args.chunk_size}",
        f"--policy.dim_feedforward={args.dim_feedforward}",
        f"--policy.n_encoder_layers={args.n_encoder_layers}",
        f"--policy.n_decoder_layers={args.n_decoder_layers}",
        "--policy.normalization_mapping=" + json.dumps({**mapping, "ENV": args.normalize_env}),
        f"--policy.n_action_steps={n_action}",
        f"--policy.optimizer_lr={args.lr}",
        f"--steps={args.steps}",
        f"--batch_size={args.batch_size}",
        f"--num_workers={args.num_workers}",
        f"--seed={seed}",
        f"--save_freq={min(args.save_freq, args.steps)}",
        "--log_freq=200",
        "--wandb.enable=false",
        f"--output_dir={out}",
        *extra,
        *_schedule(args),
        *input_features(args, dataset),
        *args.train_arg,
    ]
