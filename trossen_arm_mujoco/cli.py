"""``trossen-mujoco`` command: one entry point for every script.

Subcommands: ``record`` (scripts/record_sim_episodes.py), ``visualize``
(scripts/visualize_eps.py), ``replay-real`` (scripts/replay_episode_real.py), ``export``
(scripts/export_dataset.py), ``eval`` (scripts/eval_policy.py), ``prepare``
(scripts/prepare_checkpoint.py), ``serve``
(scripts/serve.py), ``teleop`` (scripts/teleop.py), ``train`` (scripts/train.py).

Docs: docs/cli/index.md.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

from trossen_arm_mujoco.errors import report_error, run_cli, unknown_name_error

__all__ = ["SUBCOMMANDS", "USAGE", "main"]

SUBCOMMANDS = {
    "record": "trossen_arm_mujoco.scripts.record_sim_episodes",
    "visualize": "trossen_arm_mujoco.scripts.visualize_eps",
    "replay-real": "trossen_arm_mujoco.scripts.replay_episode_real",
    "export": "trossen_arm_mujoco.scripts.export_dataset",
    "eval": "trossen_arm_mujoco.scripts.eval_policy",
    "prepare": "trossen_arm_mujoco.scripts.prepare_checkpoint",
    "serve": "trossen_arm_mujoco.scripts.serve",
    "teleop": "trossen_arm_mujoco.scripts.teleop",
    "train": "trossen_arm_mujoco.scripts.train",
}

USAGE = (
    "usage: trossen-mujoco {record,visualize,replay-real,export,eval,prepare,serve,teleop,"
    "train} [flags]\n"
    "  record       scripted rollouts -> HDF5 episodes\n"
    "  visualize    HDF5 episodes -> mp4 camera grid + joint plots\n"
    "  replay-real  replay an episode on two arms (or their simulated twin)\n"
    "  export       HDF5 episodes -> LeRobot v3.0 dataset (parquet + mp4)\n"
    "  eval         score a policy (LeRobot checkpoint, scripted, module:function) in the sim\n"
    "  prepare      make LeRobot checkpoints deployable by any runner (images, limits)\n"
    "  serve        serve the simulated kit over the arms' wire protocol (loopback), record it\n"
    "  teleop       leader arms drive the simulated kit, recording HDF5 episodes\n"
    "  train        record, export, train ACT over seeds, score each checkpoint (resumes)\n"
    "Run 'trossen-mujoco <subcommand> --help' for its flags."
)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``trossen-mujoco <command> [flags]``: import the command's module and run its
    ``cli``. Returns the exit status (0 done, 2 a user error, 130/143 interrupted)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(USAGE)
        return 0
    name, rest = args[0], args[1:]
    if name not in SUBCOMMANDS:
        return report_error(
            unknown_name_error("subcommand", name, SUBCOMMANDS, "see 'trossen-mujoco --help'")
        )
    loaded = []  # the import takes a moment: Ctrl-C or SIGTERM meanwhile ends with one line
    status = run_cli(lambda _: loaded.append(importlib.import_module(SUBCOMMANDS[name])))
    if not loaded:
        return status
    return int(loaded[0].cli(rest) or 0)


if __name__ == "__main__":
    sys.exit(main())
