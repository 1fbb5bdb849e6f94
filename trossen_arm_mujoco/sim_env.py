"""Joint-position simulation of the Stationary AI kit, behaving like the real arms.

Action, 16 values in the qpos layout: ``[left joint_0..5 (rad), left fingers x2 (m), right
joint_0..5, right fingers x2]``; each arm's 6 joints and its gripper (the finger value at
index 7 / 15) go to position actuators, the coupled finger values (6 / 14) are not
commanded. ``TrossenAIStationaryTask`` is the base of custom tasks; ``TransferCubeTask`` the
registered cube transfer (``BOX_POSE[0] = pose`` before ``env.reset()`` places its cube);
any registered task: ``tasks.dm_tasks.dm_task_class(name, "joint")``. ``python
trossen_arm_mujoco/sim_env.py`` runs a short demo.

Docs: docs/reference/dm-control-envs.md, docs/vendor-api.md.
"""

from __future__ import annotations

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

from trossen_arm_mujoco.tasks.dm_tasks import BOX_POSE, TransferCubeTask
from trossen_arm_mujoco.tasks.stationary import TrossenAIStationaryTask

__all__ = ["BOX_POSE", "TransferCubeTask", "TrossenAIStationaryTask"]

if __name__ == "__main__":
    from trossen_arm_mujoco.demo import demo_main

    raise SystemExit(demo_main("joint"))
