"""The ``eval`` and ``wire`` phases of ``trossen-mujoco train``: each run's last checkpoint
prepared (``trossen-mujoco prepare``: the dataset's settings beside its weights, its images
cut as trained, the pose encoder, the controller's limits) and scored by ``trossen-mujoco
eval``, in the sim (``eval``: ``--eval_workers`` processes, the controller's checks on and,
with ``--controller_checks both``, off beside it) or through the served kit in wall-clock
time (``wire``). One function, :func:`score`, does both; a score that already covers the
checkpoint as this call would make it is kept.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
from pathlib import Path

from trossen_arm_mujoco.errors import UserError, describe_os_error
from trossen_arm_mujoco.train.jobs import JobSpec, cli_command, run_jobs
from trossen_arm_mujoco.train.report import alike, report, results
from trossen_arm_mujoco.train.training import carry_settings
from trossen_arm_mujoco.train.workspace import Workspace

__all__ = ["BACKENDS", "already_scored", "prepare", "score", "score_all"]

#: The phase of each backend: ``sim`` scores in-process (``eval``), ``wire`` served.
BACKENDS = {"eval": "sim", "wire": "wire"}


def already_scored(info_path: Path, ckpt: Path, args: argparse.Namespace, both: bool) -> bool:
    """Whether ``info_path`` already scores ``ckpt`` as this call would (the same episodes,
    seed and level, newer than the checkpoint's weights and postprocessor, with the
    unconstrained score when ``both``).

    Args:
        info_path: the run's ``eval_info.json``.
        ckpt: the checkpoint folder it should score.
        args: the parsed flags of ``trossen-mujoco train``.
        both: the unconstrained score is asked for too.
    """
    try:
        info = json.loads(info_path.read_text(encoding="utf-8"))
        run = info["run"]
        made = max(
            (ckpt / name).stat().st_mtime
            for name in ("model.safetensors", "policy_postprocessor.json")
        )
        newer = info_path.stat().st_mtime > made
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return (
        newer
        and Path(run.get("policy", "")).resolve() == ckpt.resolve()
        and run.get("num_episodes") == args.eval_episodes
        and run.get("seed") == args.eval_seed
        # the same evaluation level: nominal, train (the task's section) or hard (widened)
        and bool(run.get("randomize")) == (args.eval_randomize != "nominal")
        and (run.get("randomization") is None) == (args.eval_randomize != "hard")
        and (not both or "unconstrained" in info)
    )


def prepare(ws: Workspace, args: argparse.Namespace, python: str, seed: int) -> Path:
    """The run's last checkpoint, made deployable before it is scored: the dataset's
    settings beside its weights (when the train phase ran elsewhere), then ``trossen-mujoco
    prepare`` (with the derived dataset's encoder for the camera_pose recipes).

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        seed: the training seed of the run.
    """
    ckpt = ws.checkpoint(seed)
    if not ckpt.is_dir():
        raise UserError(f"no checkpoint at {ckpt}: run --phase train first")
    dataset = ws.training_dataset(args.pose_encoder)
    if ws.exported(dataset):
        carry_settings(dataset, ws.train_dir(seed))  # the same file when already there
    command = [*cli_command(python), "prepare", str(ckpt)]
    if args.pose_encoder:
        encoder, camera = ws.encoder()
        command += ["--encoder", str(encoder), "--camera", camera]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except OSError as exc:
        raise UserError(f"cannot start prepare: {python}: {describe_os_error(exc)}") from None
    if done.returncode != 0:
        why = (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[-1]
        raise UserError(f"prepare {ckpt} failed: {why}")
    if "added" in done.stdout:
        print(done.stdout.strip())
    return ckpt


def score(
    ws: Workspace,
    args: argparse.Namespace,
    python: str,
    env: dict[str, str],
    seed: int,
    backend: str,
) -> None:
    """Score the last checkpoint of ``seed`` with ``trossen-mujoco eval`` on ``backend``
    (``sim`` or ``wire``) over ``--eval_episodes`` evaluation seeds; its results into the
    summary's run (``wire`` under its own key).

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
        seed: the training seed of the run.
        backend: ``sim`` or ``wire``.
    """
    ckpt = prepare(ws, args, python, seed)
    out = ws.eval_dir(seed, backend)
    wire = backend == "wire"
    name = f"{'wire' if wire else 'eval'} seed {seed}"
    run = ws.runs.setdefault(str(seed), {})
    both = not wire and args.controller_checks == "both"
    if already_scored(out / "eval_info.json", ckpt, args, both):
        print(f"{name}: {out} already holds its scores")
    else:
        command = [
            *cli_command(python),
            "eval",
            *(["--backend", "wire"] if wire else []),
            "--policy",
            str(ckpt),
            "--task_name",
            args.task,
            "--num_episodes",
            str(args.eval_episodes),
            *([] if wire else ["--num_workers", str(args.eval_workers)]),
            "--seed",
            str(args.eval_seed),
            "--output_dir",
            str(out),
            "--overwrite",
            *(
                []
                if wire
                else ["--controller_checks", args.controller_checks]
                + ["--randomize", args.eval_randomize]
            ),
            *(
                ["--episode_length", str(args.eval_episode_length)]
                if args.eval_episode_length
                else []
            ),
        ]
        log = ws.log(f"{'wire' if wire else 'eval'}_seed_{seed}")
        run["wire_eval" if wire else "eval"] = run_jobs([JobSpec(name, command, log)], env)[0]
    if wire:
        run["wire"] = results(out / "eval_info.json")
    else:
        run.update(results(out / "eval_info.json"))
    ws.save()


def score_all(
    ws: Workspace,
    args: argparse.Namespace,
    python: str,
    env: dict[str, str],
    seeds: list[int],
    backend: str,
) -> None:
    """Score every run of ``seeds`` on ``backend``, then the spread over them (in the sim,
    also over every run of the folder trained and scored alike: ``spread_all``).

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
        env: the children's environment variables (threads, paths).
        seeds: the training seeds of the runs.
        backend: ``sim`` or ``wire``.
    """
    for seed in seeds:
        score(ws, args, python, env, seed, backend)
    mine = [str(seed) for seed in seeds]
    runs = ws.runs
    if backend == "wire":
        wired = {s: runs[s]["wire"] for s in mine if "wire" in runs.get(s, {})}
        ws.summary["spread_wire"] = report(wired, "wire")
    else:
        ws.summary["spread"] = report({s: runs[s] for s in mine if s in runs})
        every = alike(runs, mine)  # runs added by earlier calls, trained and scored alike
        ws.summary.pop("spread_all", None)
        if set(every) - set(mine):
            ws.summary["spread_all"] = report(every, f"every alike run in {ws.root}", each=False)
    ws.save()
