"""Bimanual cube transfer: the reward (0-4) and the cube's spawn distribution.

This is the one implementation of the transfer-cube reward; the dm_control envs, the
gymnasium env and the recording pipeline all call it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from trossen_arm_mujoco.names import lookup_id

#: Cube spawn region on the table (world frame, m): x, y uniform; z = resting height.
BOX_X_RANGE = (-0.15, 0.15)
BOX_Y_RANGE = (-0.2, 0.1)
TABLE_TOP_Z = 0.02
BOX_HALF_SIZE = 0.0125
BOX_REST_Z = TABLE_TOP_Z + BOX_HALF_SIZE
MAX_REWARD = 4


def sample_cube_pose(rng: np.random.Generator) -> np.ndarray:
    """Random cube pose resting on the table: [x, y, z, 1, 0, 0, 0] (world, m)."""
    x = rng.uniform(*BOX_X_RANGE)
    y = rng.uniform(*BOX_Y_RANGE)
    return np.array([x, y, BOX_REST_Z, 1.0, 0.0, 0.0, 0.0])


class TransferCubeReward:
    """Reward of the transfer: 1 right gripper touches the cube, 2 and the cube is off the
    table, 3 left gripper touches it, 4 left touches it and it is off the table.

    Geom ids are looked up once here; calls only scan ``data.contact``.
    """

    def __init__(self, model: mujoco.MjModel):
        self.box = lookup_id(model, "geom", "red_box")
        self.table = lookup_id(model, "geom", "table")
        self.left = {
            lookup_id(model, "geom", f"left/gripper_follower_{f}") for f in ("left", "right")
        }
        self.right = {
            lookup_id(model, "geom", f"right/gripper_follower_{f}") for f in ("left", "right")
        }

    def touching(self, data: mujoco.MjData) -> tuple[bool, bool, bool]:
        """(right gripper touches cube, left gripper touches cube, cube touches table)."""
        partners = set()
        for i in range(data.ncon):
            g1, g2 = int(data.contact.geom1[i]), int(data.contact.geom2[i])
            if g1 == self.box:
                partners.add(g2)
            elif g2 == self.box:
                partners.add(g1)
        return bool(partners & self.right), bool(partners & self.left), self.table in partners

    def __call__(self, data: mujoco.MjData) -> int:
        right, left, table = self.touching(data)
        reward = 0
        if right:
            reward = 1
        if right and not table:
            reward = 2
        if left:
            reward = 3
        if left and not table:
            reward = 4
        return reward
