"""Shared pieces of the task tests: headless rendering and a scripted IK driver."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from trossen_arm_mujoco.robot.kinematics import Kinematics  # noqa: E402

#: tool frame pointing straight down (x axis of ee_site along -z world), quat wxyz.
DOWN = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])


class IKDriver:
    """Moves a single-arm task's tool frame along straight lines with the robot layer's IK
    (``Kinematics.solve``), sending joint_position commands through ``task.step``."""

    def __init__(self, task):
        self.task = task
        arm = task.arm
        self.kin = Kinematics(
            task.scene.model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range
        )

    def move_to(self, target, gripper: float, step: float = 0.01, settle: int = 10) -> None:
        """Straight line to ``target`` (m) in steps of ``step`` m, then ``settle`` steps."""
        start = self.task.ee_pos()
        n = max(1, int(np.ceil(np.linalg.norm(np.asarray(target) - start) / step)))
        for i in range(1, n + settle + 1):
            point = start + min(i, n) / n * (np.asarray(target) - start)
            q, _ = self.kin.solve(self.task.data.qpos, point, DOWN, iterations=50)
            self.task.step({"arm": q, "gripper": np.array([gripper])})


@pytest.fixture
def ik_driver():
    return IKDriver
