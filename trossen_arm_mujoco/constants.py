"""Constants of the documented public surface.

``START_ARM_POSE`` and all qpos/action vectors use the 16-value layout: left arm then
right arm, each 6 revolute joints (rad) followed by 2 finger joints (m, 0 closed to
0.044 open; the two fingers of one gripper are coupled).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

#: Policy / control period of the scripted envs and of recorded data (s).
DT: float = 0.02

#: Package assets (MJCF, URDF).
ASSETS_DIR: str = str(Path(__file__).resolve().parent / "assets")

#: Default root folder for recorded datasets.
ROOT_DIR: str = os.path.expanduser("~/.trossen/mujoco/data/")

#: Gripper finger travel (m): fully open and closed on the 25 mm cube.
GRIPPER_OPEN: float = 0.044
GRIPPER_CLOSED: float = 0.012

#: Arm pose at episode start, 16 values:
#: [left j0..j5, left fingers x2, right j0..j5, right fingers x2].
START_ARM_POSE: list[float] = [
    0.0, np.pi / 12, np.pi / 12, 0.0, 0.0, 0.0, GRIPPER_OPEN, GRIPPER_OPEN,
    0.0, np.pi / 12, np.pi / 12, 0.0, 0.0, 0.0, GRIPPER_OPEN, GRIPPER_OPEN,
]  # fmt: skip

#: Camera names of the Stationary AI kit, in recording order.
STATIONARY_CAMERAS: list[str] = ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]

#: Per-task defaults of the recording script; command-line flags override them.
SIM_TASK_CONFIGS: dict[str, dict] = {
    "sim_transfer_cube": {
        "num_episodes": 1,
        "episode_len": 600,
        "onscreen_render": False,
        "inject_noise": False,
        "cam_names": list(STATIONARY_CAMERAS),
    },
}
