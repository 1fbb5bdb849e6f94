"""The whole loop, measured: record -> export -> lerobot-train (ACT) -> trossen-mujoco eval.

    TROSSEN_LEROBOT_PYTHON=~/.cache/trossen-arm-mujoco/lerobot-venv/bin/python \\
        python benchmarks/train_eval.py --episodes 50 --steps 6000 --eval_episodes 50

1. ``trossen-mujoco record`` of ``--episodes`` scripted transfer episodes (``--seed``), no
   camera by default (``--cam_names cam_high --image_size 96x128 --no_env_state`` for the
   image recipe);
2. ``trossen-mujoco export`` in the real kit's 14-value layout (state, velocity,
   environment_state = the cube's pose, action);
3. LeRobot's own ``lerobot-train`` with ACT (the settings below; CPU unless ``--device``);
4. ``trossen-mujoco eval`` of the last checkpoint over ``--eval_episodes`` evaluation seeds
   (a stream of its own: never a training episode).

Prints one line per phase with its wall and CPU time, and the success rate with its 95 %
Wilson interval and the stage rates; writes ``summary.json`` in ``--work_dir``. LeRobot runs
in ``TROSSEN_LEROBOT_PYTHON`` (Python >= 3.12; ``bash .ci/run`` builds one).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(name: str, args: list[str], log: Path, env: dict) -> dict:
    start, cpu = time.perf_counter(), _cpu()
    with open(log, "w") as out:
        proc = subprocess.run(args, stdout=out, stderr=subprocess.STDOUT, env=env)
    took = {"wall_s": time.perf_counter() - start, "cpu_s": _cpu() - cpu}
    print(f"{name}: {took['wall_s']:.0f} s wall, {took['cpu_s']:.0f} s CPU (log {log})",
          flush=True)  # fmt: skip
    if proc.returncode != 0:
        sys.exit(f"{name} failed (exit {proc.returncode}); see {log}")
    return took


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
        sys.exit("--no_env_state needs a camera: pass --cam_names (e.g. cam_high)")
    return ["--policy.input_features=" + json.dumps(inputs)]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work_dir", default="train_eval_out")
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--cam_names", default="none")
    p.add_argument("--image_size", default="96x128")
    p.add_argument("--fps", type=int, default=50, help="export (and eval) rate")
    p.add_argument("--steps", type=int, default=6000)
    p.add_argument("--batch_size", type=int, default=16)
    p.add_argument("--save_freq", type=int, default=1000, help="checkpoint every N steps")
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument("--dim_model", type=int, default=256)
    p.add_argument("--chunk_size", type=int, default=50)
    p.add_argument("--use_vae", default="false")
    p.add_argument("--dim_feedforward", type=int, default=1024)
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
        "images (the image recipe)",
    )
    p.add_argument("--device", default="cpu")
    p.add_argument("--eval_episodes", type=int, default=50)
    p.add_argument("--eval_workers", type=int, default=2)
    p.add_argument("--eval_seed", type=int, default=0)
    args = p.parse_args()
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python:
        sys.exit("set TROSSEN_LEROBOT_PYTHON to a Python >= 3.12 with LeRobot (bash .ci/run)")
    work = Path(args.work_dir).resolve()
    work.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "MUJOCO_GL": "egl", "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled"}
    cli = [python, "-m", "trossen_arm_mujoco.cli"]
    summary: dict = {"settings": vars(args)}
    data, dataset, train = work / "episodes", work / "dataset", work / "train"
    if not (data / f"episode_{args.episodes - 1}.hdf5").exists():
        summary["record"] = _run("record", cli + [
            "record", "--data_dir", str(data), "--num_episodes", str(args.episodes),
            "--seed", str(args.seed), "--cam_names", args.cam_names,
            "--image_size", args.image_size, "--num_workers", "2", "--skip_failed",
        ], work / "record.log", env)  # fmt: skip
    if not (dataset / "meta/info.json").exists():
        summary["export"] = _run("export", cli + [
            "export", "--data_dir", str(data), "--output", str(dataset),
            "--repo_id", "local/transfer_cube", "--fps", str(args.fps), "--vcodec", "h264",
        ], work / "export.log", env)  # fmt: skip
    summary["train"] = _run("lerobot-train", [
        python, "-m", "lerobot.scripts.lerobot_train",
        "--dataset.repo_id=local/transfer_cube", f"--dataset.root={dataset}",
        "--policy.type=act", f"--policy.device={args.device}", "--policy.push_to_hub=false",
        "--policy.pretrained_backbone_weights=null", f"--policy.use_vae={args.use_vae}",
        f"--policy.dim_model={args.dim_model}", f"--policy.chunk_size={args.chunk_size}",
        f"--policy.dim_feedforward={args.dim_feedforward}",
        "--policy.normalization_mapping=" + json.dumps({
            "VISUAL": "MEAN_STD", "STATE": "MEAN_STD", "ACTION": "MEAN_STD",
            "ENV": args.normalize_env,
        }),
        f"--policy.n_action_steps={args.chunk_size}", f"--policy.optimizer_lr={args.lr}",
        f"--steps={args.steps}", f"--batch_size={args.batch_size}", "--num_workers=0",
        f"--save_freq={min(args.save_freq, args.steps)}", "--log_freq=200", "--wandb.enable=false",
        f"--output_dir={train}",
    ] + _inputs_flag(args, dataset), work / "train.log", env)  # fmt: skip
    losses = [
        float(part.split(":")[1])
        for line in (work / "train.log").read_text().splitlines()
        for part in line.split()
        if part.startswith("loss:")
    ]
    summary["loss_curve"] = losses
    ckpt = train / "checkpoints" / "last" / "pretrained_model"
    summary["eval"] = _run("eval", cli + [
        "eval", "--policy", str(ckpt), "--num_episodes", str(args.eval_episodes),
        "--num_workers", str(args.eval_workers), "--seed", str(args.eval_seed),
        "--fps", str(args.fps), "--output_dir", str(work / "eval"), "--overwrite",
    ], work / "eval.log", env)  # fmt: skip
    info = json.loads((work / "eval" / "eval_info.json").read_text())["aggregated"]
    summary["result"] = info
    (work / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    lo, hi = info["pc_success_ci95"]
    print(f"loss {losses[0] if losses else float('nan'):.3f} -> "
          f"{losses[-1] if losses else float('nan'):.3f} over {args.steps} steps")  # fmt: skip
    print(f"success {info['pc_success']:.1f}% (95% CI {lo:.1f}-{hi:.1f}) over "
          f"{info['n_episodes']} episodes; stages {info['stages']}")  # fmt: skip


if __name__ == "__main__":
    main()
