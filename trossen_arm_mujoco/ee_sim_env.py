"""End-effector (mocap) simulation of the Stationary AI kit.

Each arm's link_6 is welded to a mocap body; the action moves the mocap bodies (tool-frame
poses) and the gripper actuators: 16 values ``[left xyz (m), left quat wxyz, left gripper
(m), right xyz, right quat wxyz, right gripper]`` (world frame; gripper = finger travel, 0
closed .. 0.044 open). ``TrossenAIStationaryEETask`` is the base of custom tasks;
``TransferCubeEETask`` the registered cube transfer; any registered task:
``tasks.dm_tasks.dm_task_class(name, "ee")``. ``python trossen_arm_mujoco/ee_sim_env.py``
runs a short demo.

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

from trossen_arm_mujoco.tasks.dm_tasks import TransferCubeEETask
from trossen_arm_mujoco.tasks.stationary import TrossenAIStationaryEETask

__all__ = ["TransferCubeEETask", "TrossenAIStationaryEETask"]

if __name__ == "__main__":
    from trossen_arm_mujoco.demo import demo_main

    raise SystemExit(demo_main("ee"))
