"""``trossen-mujoco train``: the whole loop, measured over several training runs: record ->
export -> (encode) -> lerobot-train (ACT) -> trossen-mujoco eval (-> the wire, when asked).

    trossen-mujoco train --inject_noise --train_seeds 3 --train_jobs 3
    trossen-mujoco train --recipe camera_pose --train_seeds 3 --train_jobs 3

``--phase`` runs any subset (``record,export,encode`` here, ``train`` on a GPU machine,
``eval`` back here): each phase reads what the earlier ones left in ``--work_dir``
(:mod:`.workspace`) and skips what is already whole, so a rerun resumes. One run works in a
folder at a time (its lock); Ctrl-C and SIGTERM stop the children with their workers. At the
end: each run's success with its 95 % Wilson interval, the mean and the worst, the cost of
each part (wall and CPU seconds) and where each checkpoint landed; everything is merged into
``summary.json``. LeRobot runs in the Python :func:`.lerobot_python.lerobot_python` finds.

Docs: docs/cli/train.md, docs/train-eval.md; measured: docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from trossen_arm_mujoco.errors import (
    UserError,
    describe_os_error,
    interrupt_note,
    os_error_hint,
    run_cli,
)
from trossen_arm_mujoco.train.encoding import encode
from trossen_arm_mujoco.train.flags import build_parser, parse_args, phases_of
from trossen_arm_mujoco.train.jobs import child_env
from trossen_arm_mujoco.train.lerobot_python import lerobot_python
from trossen_arm_mujoco.train.recording import export, record
from trossen_arm_mujoco.train.report import cost, print_cost
from trossen_arm_mujoco.train.scoring import BACKENDS, score_all
from trossen_arm_mujoco.train.training import train
from trossen_arm_mujoco.train.workspace import Workspace

__all__ = ["build_parser", "cli", "main", "run_phases"]


def run_phases(ws: Workspace, args: argparse.Namespace, python: str) -> None:
    """Run the phases ``--phase`` names, in the loop's order, in the locked ``ws``.

    Args:
        ws: the locked work folder (``train.workspace``).
        args: the parsed flags of ``trossen-mujoco train``.
        python: the Python that runs LeRobot and the project's commands (``lerobot_python``).
    """
    phases = phases_of(args)
    env = child_env()
    seeds = [args.train_seed + k for k in range(args.train_seeds)]
    ws.load_summary()
    ws.summary.setdefault("settings", {})[",".join(phases)] = vars(args)
    if "record" in phases:
        record(ws, args, python, env)
    if "export" in phases:
        export(ws, args, python, env)
    ws.save()
    if args.pose_encoder and ("encode" in phases or "train" in phases):
        encode(ws, args, python, env, asked="encode" in phases)
    if "train" in phases:
        train(ws, args, python, env, seeds)
    for phase, backend in BACKENDS.items():
        if phase in phases:
            score_all(ws, args, python, env, seeds, backend)
    print_cost(cost(ws.summary, [str(s) for s in seeds]))
    for seed in seeds:
        ckpt = ws.checkpoint(seed)
        print(f"checkpoint seed {seed}: {ckpt if ckpt.is_dir() else 'none yet'}")
    print(f"summary: {ws.summary_path}")


def main(argv: Sequence[str] | None = None) -> int:
    """Parse the flags, find LeRobot's Python, lock the work folder and run the phases."""
    args = parse_args(argv)
    python = lerobot_python()
    ws = Workspace.open(args.work_dir)
    with (
        ws.locked(),
        interrupt_note(lambda: f"stopped; rerun the same command to resume in {ws.root}"),
    ):
        try:
            run_phases(ws, args, python)
        except OSError as exc:  # the work folder turned read-only, the disk filled up
            where = getattr(exc, "filename", None) or ws.root
            raise UserError(
                f"cannot write {where}: {describe_os_error(exc)}; "
                f"{os_error_hint(exc, '--work_dir')}"
            ) from None
    return 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2."""
    return run_cli(main, argv)
