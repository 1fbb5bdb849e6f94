"""Constants of the documented public surface.

``START_ARM_POSE`` and all qpos/action vectors use the 16-value layout: left arm then
right arm, each 6 revolute joints (rad) followed by 2 finger joints (m, 0 closed to
0.044 open; the two fingers of one gripper are coupled); see ``robot.layout``.

The values live in the layers that own them (``robot.layout``, ``assets``, ``tasks``); this
module gathers them under their documented names. ``SIM_TASK_CONFIGS`` is derived from the
task registry: one entry per task with a scripted policy. Importing this module reads no
task config; ``SIM_TASK_CONFIGS[name]`` checks that task's YAML file (``RecordDefaults``).

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

import os

from trossen_arm_mujoco.assets import ASSETS_DIR
from trossen_arm_mujoco.assets import STATIONARY_CAMERAS as _CAMERAS
from trossen_arm_mujoco.robot.layout import GRIPPER_CLOSED, GRIPPER_OPEN, START_ARM_POSE
from trossen_arm_mujoco.tasks.registry import RecordDefaults
from trossen_arm_mujoco.tasks.task import DEFAULT_POLICY_DT

__all__ = [
    "ASSETS_DIR",
    "DT",
    "GRIPPER_CLOSED",
    "GRIPPER_OPEN",
    "ROOT_DIR",
    "SIM_TASK_CONFIGS",
    "START_ARM_POSE",
    "STATIONARY_CAMERAS",
]

#: Policy / control period of the scripted envs and of recorded data (s).
DT: float = DEFAULT_POLICY_DT

#: Default root folder for recorded datasets.
ROOT_DIR: str = os.path.expanduser("~/.trossen/mujoco/data/")

#: Camera names of the Stationary AI kit, in recording order.
STATIONARY_CAMERAS: list[str] = list(_CAMERAS)

#: Per-task defaults of the recording script (num_episodes, episode_len, onscreen_render,
#: inject_noise, cam_names); command-line flags override them. Looking a task up checks its
#: YAML config (a broken one: a one-line UserError); listing reads no file.
SIM_TASK_CONFIGS: dict[str, dict] = RecordDefaults()
