"""The ``train`` phase of ``trossen-mujoco train``: LeRobot's own ``lerobot-train`` with ACT
once per training seed, ``--train_jobs`` at a time, each given its share of the CPU threads;
each run's cost, loss curve and recipe flags into the summary, and the dataset's settings
written beside every checkpoint's weights.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import write_text
from trossen_arm_mujoco.train.act_args import train_args
from trossen_arm_mujoco.train.jobs import JobSpec, cores, run_jobs
from trossen_arm_mujoco.train.report import losses, recipe_flags
from trossen_arm_mujoco.train.workspace import Workspace

__all__ = ["THREAD_VARS", "carry_settings", "train"]

#: Thread-pool sizes a training run is given (torch reads OMP_NUM_THREADS at start).
THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def carry_settings(dataset: Path, train_dir: Path) -> None:
    """Write the dataset's settings (its info.json's ``export.dataset_settings.INFO_KEY``)
    beside the weights of every checkpoint of one run, as ``CHECKPOINT_FILE``: ``eval``,
    ``prepare`` and the plugin read them there. Where the simulator is not installed (a
    train-only machine) nothing is written: the eval phase writes them before scoring."""
    try:
        from trossen_arm_mujoco.export.dataset_settings import CHECKPOINT_FILE, INFO_KEY
    except ImportError:
        return
    info = json.loads((dataset / "meta" / "info.json").read_text(encoding="utf-8"))
    settings = info.get(INFO_KEY)
    if not isinstance(settings, dict):
        return
    for model in sorted((train_dir / "checkpoints").glob("*/pretrained_model")):
        write_text(model / CHECKPOINT_FILE, json.dumps(settings, indent=2) + "\n")


def train(
    ws: Workspace, args: argparse.Namespace, python: str, env: dict[str, str], seeds: list[int]
) -> None:
    """Train every seed without a checkpoint; a run stopped before its first checkpoint is
    removed, so the next call trains it again.

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
        seeds: the training seeds.
    """
    dataset = ws.training_dataset(args.pose_encoder)
    if not ws.exported(dataset):
        raise UserError(f"no dataset in {dataset}: run --phase record,export first")
    todo = []
    for seed in seeds:
        out = ws.train_dir(seed)
        if ws.checkpoint(seed).is_dir():
            print(f"train seed {seed}: {out} already holds a checkpoint")
            continue
        if out.exists():
            raise UserError(f"{out} holds an unfinished run: remove it to train seed {seed} again")
        out.parent.mkdir(parents=True, exist_ok=True)
        todo.append(seed)
    at_once = min(args.train_jobs, max(1, len(todo)))
    threads = args.train_threads or max(1, cores() // at_once)
    train_env = {**env, **{k: str(threads) for k in THREAD_VARS}}
    print(f"train: {len(todo)} run(s), {at_once} at a time, {threads} CPU thread(s) each")
    specs = [
        JobSpec(
            f"lerobot-train seed {seed}",
            train_args(args, python, dataset, ws.train_dir(seed), seed),
            ws.log(f"train_seed_{seed}"),
        )
        for seed in todo
    ]
    try:
        timings = run_jobs(specs, train_env, at_once)
    except BaseException:
        for seed in todo:  # nothing saved yet: nothing to keep, train it again next time
            if not (ws.train_dir(seed) / "checkpoints").is_dir():
                shutil.rmtree(ws.train_dir(seed), ignore_errors=True)
        raise
    for seed, spec, took in zip(todo, specs, timings):
        rate = round(args.steps / took["wall_s"], 2) if took["wall_s"] > 0 else None
        ws.runs[str(seed)] = {
            "train": {
                **took,
                "steps": args.steps,
                "steps_per_s": rate,
                "device": args.device,
                "jobs_at_once": at_once,
                "threads": threads,
            },
            "loss_curve": losses(spec.log),
            "trained_with": recipe_flags(vars(args)),
        }
        ws.save()
    for seed in seeds:  # the dataset's settings travel with each checkpoint
        carry_settings(dataset, ws.train_dir(seed))
