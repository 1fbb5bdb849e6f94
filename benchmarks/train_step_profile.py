"""Where the time of one LeRobot ACT training step goes: data loading, preprocessing, forward,
backward, optimizer.

    ~/.cache/trossen-arm-mujoco/lerobot-venv/bin/python benchmarks/train_step_profile.py \\
        /tmp/prof_ds_state --steps 30 --warmup 5

Runs in a Python with LeRobot 0.6.1 (``TROSSEN_LEROBOT_PYTHON``; this project is not
imported). The dataset is a LeRobot v3.0 folder made by ``trossen-mujoco export``
(``--sim_features`` for the recipes with ``environment_state``, as ``train_eval.py``). The step is
``lerobot-train``'s, built with LeRobot's own public API and the ACT settings of
``benchmarks/train_eval.py`` (dim_model 256, dim_feedforward 1024, 4 encoder / 1 decoder
layers, chunk 50, no VAE, batch 16, lr 1e-4, resnet18 backbone without pretrained weights,
MEAN_STD normalization of every feature, environment_state included):

- dataset: ``LeRobotDataset(return_uint8=True)`` with the policy's ``delta_timestamps``
  (``resolve_delta_timestamps``), sampled by ``EpisodeAwareSampler`` (shuffled, seeded), in a
  ``torch.utils.data.DataLoader`` with ``--num_workers`` workers;
- policy: ``make_policy(ACTConfig(...), ds_meta)``; ``make_pre_post_processors(...,
  dataset_stats=meta.stats)``; AdamW from ``ACTConfig.get_optimizer_preset()`` over
  ``policy.get_optim_params()`` (backbone lr 1e-5), gradients clipped at the preset's norm
  (10).

Each measured step is split into (milliseconds, wall clock; on CUDA every part ends with a
``torch.cuda.synchronize()``):

- ``data``: waiting for the next batch (``next(loader)``): reading parquet rows and, for
  camera features, decoding the video frames; with workers, only the time the main process
  waits for them;
- ``preprocess``: uint8 images to float in [0, 1] (as ``lerobot-train`` does) and the
  policy's preprocessor (batch to the device, normalization);
- ``forward``: ``policy.forward(batch)`` (the loss);
- ``backward``: ``loss.backward()``;
- ``optimizer``: gradient clipping, ``optimizer.step()``, ``optimizer.zero_grad()``.

The first ``--warmup`` steps are run and not measured. Prints one row per part with its mean
and median wall time (ms), its share of the mean step and its mean CPU time (this process, all
threads: on a loaded machine wall time includes waiting for a core, CPU time does not), then
the step's mean and the steps per second.
``lerobot-train`` adds ``accelerate`` (a no-op on one CPU or GPU without mixed precision),
metrics and logging, which are not measured here.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

PARTS = ("data", "preprocess", "forward", "backward", "optimizer")


def _fail(message: str) -> None:
    sys.exit(f"error: {message}")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dataset", type=Path, help="LeRobot dataset folder (trossen-mujoco export)")
    p.add_argument("--repo_id", default=None, help="default: local/<folder name>")
    p.add_argument("--steps", type=int, default=30, help="measured steps")
    p.add_argument("--warmup", type=int, default=5, help="steps run before measuring")
    p.add_argument("--batch_size", type=int, default=16)
    p.add_argument("--num_workers", type=int, default=0, help="DataLoader workers")
    p.add_argument("--device", default="cpu", help="cpu or cuda")
    p.add_argument("--threads", type=int, default=0, help="torch CPU threads (0: torch's)")
    p.add_argument("--video_backend", default=None, help="torchcodec or pyav (LeRobot's default)")
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument("--dim_model", type=int, default=256)
    p.add_argument("--dim_feedforward", type=int, default=1024)
    p.add_argument("--n_encoder_layers", type=int, default=4)
    p.add_argument("--n_decoder_layers", type=int, default=1)
    p.add_argument("--chunk_size", type=int, default=50)
    p.add_argument("--use_vae", action="store_true")
    p.add_argument(
        "--no_env_state",
        action="store_true",
        help="leave observation.environment_state out (the camera recipe)",
    )
    p.add_argument(
        "--no_images",
        action="store_true",
        help="leave the cameras out: the joints and observation.environment_state only (the "
        "camera_pose recipe, whose poses a frozen encoder estimated once, before training)",
    )
    p.add_argument("--vision_backbone", default="resnet18", help="ACT's torchvision backbone")
    p.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = p.parse_args(argv)
    if not (args.dataset / "meta" / "info.json").is_file():
        _fail(
            f"{args.dataset} is not a LeRobot dataset (no meta/info.json); make one with "
            "trossen-mujoco export"
        )
    if args.steps < 1 or args.warmup < 0 or args.batch_size < 1 or args.num_workers < 0:
        _fail("--steps and --batch_size must be >= 1, --warmup and --num_workers >= 0")
    return args


def build(args: argparse.Namespace):
    """(dataset, loader iterator, policy, preprocessor, optimizer, grad clip norm, device)."""
    import torch
    from lerobot.configs.types import NormalizationMode
    from lerobot.datasets import (
        EpisodeAwareSampler,
        LeRobotDataset,
        LeRobotDatasetMetadata,
        resolve_delta_timestamps,
    )
    from lerobot.policies import make_policy, make_pre_post_processors
    from lerobot.policies.act.configuration_act import ACTConfig

    torch.manual_seed(args.seed)
    if args.threads > 0:
        torch.set_num_threads(args.threads)
    repo_id = args.repo_id or f"local/{args.dataset.name}"
    meta = LeRobotDatasetMetadata(repo_id, root=args.dataset)
    mean_std = NormalizationMode.MEAN_STD
    config = ACTConfig(
        device=args.device,
        push_to_hub=False,
        pretrained_backbone_weights=None,
        use_vae=args.use_vae,
        dim_model=args.dim_model,
        dim_feedforward=args.dim_feedforward,
        n_encoder_layers=args.n_encoder_layers,
        n_decoder_layers=args.n_decoder_layers,
        chunk_size=args.chunk_size,
        n_action_steps=args.chunk_size,
        optimizer_lr=args.lr,
        vision_backbone=args.vision_backbone,
        normalization_mapping={k: mean_std for k in ("VISUAL", "STATE", "ENV", "ACTION")},
    )
    if args.no_env_state:  # every other observation feature, as lerobot-train would
        from lerobot.configs.types import FeatureType, PolicyFeature

        config.input_features = {
            key: PolicyFeature(
                type=FeatureType.VISUAL
                if key.startswith("observation.images.")
                else FeatureType.STATE,
                shape=tuple(ft["shape"][::-1][:1] + ft["shape"][:2])
                if key.startswith("observation.images.")
                else tuple(ft["shape"]),
            )
            for key, ft in meta.features.items()
            if key == "observation.state" or key.startswith("observation.images.")
        }
    if args.no_images:
        from lerobot.configs.types import FeatureType, PolicyFeature

        kinds = {
            "observation.state": FeatureType.STATE,
            "observation.environment_state": FeatureType.ENV,
        }
        config.input_features = {
            key: PolicyFeature(type=kind, shape=tuple(meta.features[key]["shape"]))
            for key, kind in kinds.items()
            if key in meta.features
        }
    policy = make_policy(config, ds_meta=meta)
    dataset = LeRobotDataset(
        repo_id,
        root=args.dataset,
        delta_timestamps=resolve_delta_timestamps(config, meta),
        video_backend=args.video_backend,
        return_uint8=True,
    )
    preprocessor, _ = make_pre_post_processors(config, dataset_stats=dataset.meta.stats)
    preset = config.get_optimizer_preset()
    optimizer = preset.build(policy.get_optim_params())
    sampler = EpisodeAwareSampler(
        dataset.meta.episodes["dataset_from_index"],
        dataset.meta.episodes["dataset_to_index"],
        episode_indices_to_use=dataset.episodes,
        shuffle=True,
        seed=args.seed,
    )
    device = torch.device(args.device)
    loader = torch.utils.data.DataLoader(
        dataset,
        batch_size=args.batch_size,
        sampler=sampler,
        num_workers=args.num_workers,
        pin_memory=device.type == "cuda",
        drop_last=False,
        persistent_workers=args.num_workers > 0,
    )

    def batches():
        while True:  # as lerobot's cycle(): a new pass (epoch) when one ends
            yield from loader

    return dataset, batches(), policy, preprocessor, optimizer, preset.grad_clip_norm, device


def profile(args: argparse.Namespace) -> dict:
    """Run the steps; per part the measured times (s) of every measured step."""
    import torch

    dataset, batches, policy, preprocessor, optimizer, clip, device = build(args)
    cameras = list(dataset.meta.camera_keys)
    sync = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    times: dict[str, list[float]] = {part: [] for part in PARTS}
    cpu: dict[str, list[float]] = {part: [] for part in PARTS}
    losses = []
    policy.train()
    for step in range(args.warmup + args.steps):
        sync()
        t0, c0 = time.perf_counter(), time.process_time()
        batch = next(batches)
        t1, c1 = time.perf_counter(), time.process_time()
        for key in cameras:
            if key in batch and batch[key].dtype == torch.uint8:
                batch[key] = batch[key].to(dtype=torch.float32) / 255.0
        batch = preprocessor(batch)
        sync()
        t2, c2 = time.perf_counter(), time.process_time()
        loss, _ = policy.forward(batch)
        sync()
        t3, c3 = time.perf_counter(), time.process_time()
        loss.backward()
        sync()
        t4, c4 = time.perf_counter(), time.process_time()
        if clip > 0:
            torch.nn.utils.clip_grad_norm_(policy.parameters(), clip)
        optimizer.step()
        optimizer.zero_grad()
        sync()
        t5, c5 = time.perf_counter(), time.process_time()
        losses.append(float(loss.detach()))
        if step >= args.warmup:
            for part, dt, dc in zip(
                PARTS,
                (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4),
                (c1 - c0, c2 - c1, c3 - c2, c4 - c3, c5 - c4),
            ):
                times[part].append(dt)
                cpu[part].append(dc)
    n_params = sum(p.numel() for p in policy.parameters() if p.requires_grad)
    return {
        "dataset": str(args.dataset),
        "frames": int(dataset.num_frames),
        "episodes": int(dataset.num_episodes),
        "cameras": cameras,
        "image_shapes": {k: list(dataset.meta.features[k]["shape"]) for k in cameras},
        "video_backend": getattr(dataset, "_video_backend", None) if cameras else None,
        "inputs": sorted(policy.config.input_features),
        "parameters": int(n_params),
        "device": str(device),
        "torch_threads": int(torch.get_num_threads()),
        "torch": torch.__version__,
        "cpu_count": os.cpu_count(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "batch_size": args.batch_size,
        "num_workers": args.num_workers,
        "warmup": args.warmup,
        "steps": args.steps,
        "first_loss": losses[0],
        "last_loss": losses[-1],
        "times_s": times,
        "cpu_s": cpu,
    }


def report(result: dict) -> str:
    """The table: per part mean and median wall time (ms), share of the mean step, and the
    mean CPU time of this process (ms, all its threads; loader workers not included)."""
    times = result["times_s"]
    means = {part: 1e3 * statistics.fmean(times[part]) for part in PARTS}
    medians = {part: 1e3 * statistics.median(times[part]) for part in PARTS}
    cpu = {part: 1e3 * statistics.fmean(result["cpu_s"][part]) for part in PARTS}
    step = sum(means.values())
    cams = ", ".join(
        f"{k} {'x'.join(str(v) for v in result['image_shapes'][k])}" for k in result["cameras"]
    )
    lines = [
        f"dataset {result['dataset']}: {result['episodes']} episodes, {result['frames']} frames; "
        f"cameras: {cams or 'none'} (video backend {result['video_backend']})",
        f"ACT {result['parameters'] / 1e6:.1f} M trainable parameters; inputs: "
        f"{', '.join(result['inputs'])}",
        f"device {result['device']}, torch {result['torch']}, {result['torch_threads']} torch "
        f"threads, {result['cpu_count']} CPUs, load average "
        f"{', '.join(f'{v:.1f}' for v in result['load_average'] or [])}; batch "
        f"{result['batch_size']}, {result['num_workers']} loader workers; {result['steps']} "
        f"steps after {result['warmup']} warm-up; loss {result['first_loss']:.3f} -> "
        f"{result['last_loss']:.3f}",
        "",
        "| part       | mean ms | median ms |  share | CPU ms |",
        "|------------|--------:|----------:|-------:|-------:|",
    ]
    for part in PARTS:
        lines.append(
            f"| {part:<10} | {means[part]:7.1f} | {medians[part]:9.1f} | "
            f"{100 * means[part] / step:5.1f}% | {cpu[part]:6.1f} |"
        )
    lines.append(f"| {'step':<10} | {step:7.1f} | {'':9} | 100.0% | {sum(cpu.values()):6.1f} |")
    lines.append(f"steps/s: {1e3 / step:.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    try:
        import lerobot  # noqa: F401
    except ImportError:
        _fail(
            f"LeRobot is not installed in {sys.executable} (Python {platform.python_version()});"
            " run this with the LeRobot venv's python (TROSSEN_LEROBOT_PYTHON)"
        )
    result = profile(args)
    print(report(result), flush=True)
    if args.json is not None:
        tmp = args.json.with_name(args.json.name + ".tmp")
        tmp.write_text(json.dumps(result, indent=1))
        os.replace(tmp, args.json)  # atomic


if __name__ == "__main__":
    main()
