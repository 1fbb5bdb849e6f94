"""Bimanual cube transfer: the right arm picks the cube up and hands it to the left arm.

The one implementation of this task for every front door (dm_control envs, gymnasium env,
recorder): the reward (0-4), the cube's spawn distribution, the task (``TransferCube``) and
its sampler (``TransferCubeSampler``). Config: ``config/transfer_cube.yaml``; scripted policy:
``policies/transfer_cube.py``; registered as ``sim_transfer_cube`` (alias ``transfer_cube``).

Docs: docs/gym/StationaryAITransferCube-v0.md.
"""

from __future__ import annotations

from typing import ClassVar

import mujoco
import numpy as np

from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.sim.contacts import ContactPartners
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.bimanual import BimanualSampler, BimanualTask, finger_geoms
from trossen_arm_mujoco.tasks.sampler import uniform
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

__all__ = [
    "TASKS",
    "BOX_HALF_SIZE",
    "BOX_REST_Z",
    "BOX_X_RANGE",
    "BOX_Y_RANGE",
    "MAX_REWARD",
    "TABLE_TOP_Z",
    "TransferCube",
    "TransferCubeReward",
    "TransferCubeSampler",
    "sample_cube_pose",
]

#: Cube spawn region on the table (world frame, m): x, y uniform; z = resting height.
BOX_X_RANGE = (-0.15, 0.15)
BOX_Y_RANGE = (-0.2, 0.1)
TABLE_TOP_Z = 0.02
BOX_HALF_SIZE = 0.0125
BOX_REST_Z = TABLE_TOP_Z + BOX_HALF_SIZE
MAX_REWARD = 4


def sample_cube_pose(rng: np.random.Generator) -> np.ndarray:
    """Random cube pose resting on the table: [x, y, z, 1, 0, 0, 0] (world, m)."""
    x = uniform(rng, *BOX_X_RANGE)
    y = uniform(rng, *BOX_Y_RANGE)
    return np.array([x, y, BOX_REST_Z, 1.0, 0.0, 0.0, 0.0])


class TransferCubeReward:
    """Reward of the transfer: 1 right gripper touches the cube, 2 and the cube is off the
    table, 3 left gripper touches it, 4 left touches it and it is off the table.

    Any collision geom of a finger counts (tip and pads). Geom ids are looked up once here;
    calls only scan ``data.contact``.
    """

    def __init__(self, model: mujoco.MjModel):
        self.box = lookup_id(model, "geom", "red_box")
        self.table = lookup_id(model, "geom", "table")
        self.left = finger_geoms(model, "left")
        self.right = finger_geoms(model, "right")
        self._box_partners = ContactPartners(model, [self.box])

    def touching(self, data: mujoco.MjData) -> tuple[bool, bool, bool]:
        """(right gripper touches cube, left gripper touches cube, cube touches table)."""
        partners = self._box_partners(data)
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


class TransferCube(BimanualTask):
    """Hand the cube from the right gripper to the left one, lifted off the table.
    Sparse reward 0-4 (``TransferCubeReward``); success = 4."""

    name: ClassVar[str] = "sim_transfer_cube"
    objects: ClassVar[tuple[str, ...]] = ("box",)
    max_reward: ClassVar[float] = MAX_REWARD

    def __init__(self, scene, config):
        super().__init__(scene, config)
        self.reward_fn = TransferCubeReward(scene.model)

    def get_reward(self) -> int:
        """Sparse 0-4 (see ``TransferCubeReward``)."""
        return self.reward_fn(self.data)

    def left_touches_object(self) -> bool:
        """Whether the left fingers touch the cube now (``TransferCubeReward.touching``)."""
        return self.reward_fn.touching(self.data)[1]

    def get_task_description(self) -> str:
        """The handover in words (the same for every episode)."""
        return "pick up the red cube with the right arm and hand it over to the left arm"


class TransferCubeSampler(BimanualSampler):
    """Arms at ``START_ARM_POSE``; the cube resting at ``sample_cube_pose(rng)``."""

    task_cls = TransferCube

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return {"box": ("red_box_joint", "red_box")}

    def _sample_task(self, scene: Scene) -> TransferCube:
        scene.objects["box"].set_pose(scene.data, sample_cube_pose(self.rng))
        return self.task_cls(scene, self.config)


#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "sim_transfer_cube",
        TransferCube,
        TransferCubeSampler,
        "transfer_cube",
        "Stationary AI: hand a cube from the right arm to the left",
        policy="trossen_arm_mujoco.policies.transfer_cube:PickAndTransferPolicy",
        aliases=("transfer_cube",),
        record=record_defaults(600),
        # 1 right fingers touch the cube, 2 and it is off the table, 4 the left holds it up
        stages={"touched": 1.0, "lifted": 2.0, "transferred": 4.0},
        gym_ids={"TrossenMujoco/StationaryAITransferCube-v0": "env"},
        # the cube's spawn region (x -0.15..0.15 m, y -0.2..0.1 m) projects to rows 240-343,
        # columns 286-399 of cam_high; 3:4, so a 60x80 image keeps its aspect
        camera_crop="cam_high:217,243,150,200",
        required=("ee_scene", "max_object_velocity"),
    ),
)
