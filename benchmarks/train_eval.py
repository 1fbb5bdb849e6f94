"""``trossen-mujoco train`` under its former name: the whole loop (record -> export ->
lerobot-train (ACT) -> trossen-mujoco eval) over several training runs, measured. The same
flags; the loop lives in the package (``trossen_arm_mujoco.train``, docs Train and evaluate).

    python benchmarks/train_eval.py --inject_noise --train_seeds 3 --train_jobs 3

Kept for ``benchmarks/gpu_leg.py`` and the measurements of docs/benchmarks.md that name it.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path[0] = str(Path(__file__).resolve().parents[1])  # the checkout, not benchmarks/
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)
    from trossen_arm_mujoco.train.command import cli

    sys.exit(cli())
