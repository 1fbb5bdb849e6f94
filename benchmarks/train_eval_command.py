"""The ``lerobot-train`` command line of ``train_eval.py``: ACT with the settings of its
flags (``train_eval.py --help``), the rate decayed with ``--lr_schedule cosine``, and the
policy's inputs (every ``observation.*`` feature of the dataset, less the object poses with
``--no_env_state``, the joints and the estimated poses only with ``--pose_encoder``)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from train_eval_jobs import fail
from train_eval_pose import inputs_flag


def _inputs_flag(args: argparse.Namespace, dataset: Path) -> list[str]:
    """``--policy.input_features`` without ``observation.environment_state`` when asked
    (LeRobot otherwise feeds the policy every ``observation.*`` feature of the dataset)."""
    if not args.no_env_state:
        return []
    info = json.loads((dataset / "meta" / "info.json").read_text())
    inputs = {}
    for key, ft in info["features"].items():
        if key == "observation.state":
            inputs[key] = {"type": "STATE", "shape": ft["shape"]}
        elif key.startswith("observation.images."):
            h, w, c = ft["shape"]  # LeRobot stores video features (H, W, C); policies see CHW
            inputs[key] = {"type": "VISUAL", "shape": [c, h, w]}
    if not any(k.startswith("observation.images.") for k in inputs):
        fail("--no_env_state needs a camera: pass --cam_names (e.g. cam_high)")
    return ["--policy.input_features=" + json.dumps(inputs)]


def train_args(
    args: argparse.Namespace, python: str, dataset: Path, out: Path, seed: int
) -> list[str]:
    n_action = args.n_action_steps or args.chunk_size
    extra = []
    if args.temporal_ensemble_coeff:
        extra = [f"--policy.temporal_ensemble_coeff={args.temporal_ensemble_coeff}"]
        n_action = 1
    if args.video_backend:
        extra.append(f"--dataset.video_backend={args.video_backend}")
    if args.lr_schedule == "cosine":  # ACT's own optimizer settings, the rate decayed to the end
        extra += [
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
    return (
        [
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
            "--policy.normalization_mapping="
            + json.dumps(
                {
                    "VISUAL": "MEAN_STD",
                    "STATE": "MEAN_STD",
                    "ACTION": "MEAN_STD",
                    "ENV": args.normalize_env,
                }
            ),
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
        ]
        + extra
        + (inputs_flag(dataset) if args.pose_encoder else _inputs_flag(args, dataset))
        + list(args.train_arg)
    )
