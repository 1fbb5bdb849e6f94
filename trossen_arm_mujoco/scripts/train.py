"""Record, export, train LeRobot's ACT over several seeds and score each checkpoint (also
``trossen-mujoco train``); a rerun resumes.

    trossen-mujoco train --inject_noise --train_seeds 3 --train_jobs 3
    trossen-mujoco train --recipe camera_pose --train_seeds 3 --train_jobs 3

The loop itself lives in :mod:`trossen_arm_mujoco.train.command` (one module per phase).

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

__all__ = ["build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import sys

from trossen_arm_mujoco.train.command import build_parser, cli, main

if __name__ == "__main__":
    sys.exit(cli())
