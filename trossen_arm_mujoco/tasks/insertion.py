"""Bimanual peg insertion: the left arm picks up the socket, the right arm the peg, both lift
them and the peg goes into the socket above the table.

The reward (0-4, ``InsertionReward``), the spawn distribution (``sample_insertion_poses``),
the task (``InsertionTask``) and its sampler (``InsertionSampler``), for every front door.
Config: ``config/insertion.yaml``; scenes: ``stationary_ai/trossen_ai_insertion_scene_joint.xml``
(joint) and ``stationary_ai/trossen_ai_insertion_scene.xml`` (mocap); scripted policy:
``policies/insertion.py``. Objects (world frame, m): the peg, a 20 x 20 x 120 mm bar
(``peg_joint``, qpos 16..22); the socket, a 32 x 32 x 60 mm tube (``socket_joint``, qpos
23..29) opening toward -y, its 26 x 26 mm hole leaving 3 mm around the peg.

Docs: docs/gym/StationaryAIInsertion-v0.md.
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
    "MAX_REWARD",
    "PEG_GEOM",
    "PEG_HALF",
    "PEG_REST_Z",
    "PEG_X_RANGE",
    "PEG_Y_RANGE",
    "PIN_FACE_Y",
    "PIN_GEOM",
    "SOCKET_GEOMS",
    "SOCKET_HALF_LENGTH",
    "SOCKET_INNER_HALF",
    "SOCKET_MOUTH_Y",
    "SOCKET_OUTER_HALF",
    "SOCKET_REST_Z",
    "SOCKET_X_RANGE",
    "SOCKET_Y_RANGE",
    "TABLE_GEOM",
    "TABLE_TOP_Z",
    "InsertionReward",
    "InsertionSampler",
    "InsertionTask",
    "sample_insertion_poses",
]

TABLE_TOP_Z = 0.02
#: Half-sizes of the peg (x, y, z) and outer half-size of the socket's square section (m).
PEG_HALF = (0.01, 0.06, 0.01)
SOCKET_OUTER_HALF = 0.016
SOCKET_HALF_LENGTH = 0.03
#: Inner half-size of the socket's square hole (m): 3 mm of clearance around the peg.
SOCKET_INNER_HALF = 0.013
#: Distance from the socket's centre to its mouth (-y) and to the pin's face (m, along y).
SOCKET_MOUTH_Y = -SOCKET_HALF_LENGTH
PIN_FACE_Y = 0.019
PEG_REST_Z = TABLE_TOP_Z + PEG_HALF[2]
SOCKET_REST_Z = TABLE_TOP_Z + SOCKET_OUTER_HALF

#: Spawn regions (world, m; uniform): the peg on the right half of the table (y < 0), the
#: socket on the left half (y > 0), both in front of the arms and within their reach.
PEG_X_RANGE = (-0.05, 0.10)
PEG_Y_RANGE = (-0.20, -0.10)
SOCKET_X_RANGE = (-0.05, 0.10)
SOCKET_Y_RANGE = (0.10, 0.20)
MAX_REWARD = 4

PEG_GEOM = "peg"
SOCKET_GEOMS = ("socket-1", "socket-2", "socket-3", "socket-4", "socket-bottom", "pin")
PIN_GEOM = "pin"
TABLE_GEOM = "table"


def sample_insertion_poses(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Random resting poses of the peg and the socket, each [x, y, z, 1, 0, 0, 0] (world, m):
    the peg on the right half of the table, the socket on the left half, both lying along y.
    """
    peg = np.array(
        [uniform(rng, *PEG_X_RANGE), uniform(rng, *PEG_Y_RANGE), PEG_REST_Z, 1.0, 0.0, 0.0, 0.0]
    )
    socket = np.array(
        [
            uniform(rng, *SOCKET_X_RANGE),
            uniform(rng, *SOCKET_Y_RANGE),
            SOCKET_REST_Z,
            1.0,
            0.0,
            0.0,
            0.0,
        ]
    )
    return peg, socket


class InsertionReward:
    """Reward of the insertion, 0-4 (each stage includes the ones before):

    1. both grippers touch their objects (right fingers the peg, left fingers the socket);
    2. and neither object touches the table (both lifted);
    3. and the peg touches the socket (any of its geoms);
    4. and the peg touches the ``pin`` at the socket's bottom (inserted).

    Geom ids are looked up once here; calls only scan ``data.contact``.
    """

    def __init__(self, model: mujoco.MjModel):
        self.peg = lookup_id(model, "geom", PEG_GEOM)
        self.socket = {lookup_id(model, "geom", g) for g in SOCKET_GEOMS}
        self.pin = lookup_id(model, "geom", PIN_GEOM)
        self.table = lookup_id(model, "geom", TABLE_GEOM)
        self.left = finger_geoms(model, "left")
        self.right = finger_geoms(model, "right")
        self._peg_partners = ContactPartners(model, [self.peg])
        self._socket_partners = ContactPartners(model, self.socket)

    def contacts(self, data: mujoco.MjData) -> dict[str, bool]:
        """Which of the reward's contacts exist now (names as in the stages above)."""
        peg_partners = self._peg_partners(data)
        socket_partners = self._socket_partners(data)
        pin_peg = self.pin in peg_partners
        return {
            "right_peg": bool(peg_partners & self.right),
            "left_socket": bool(socket_partners & self.left),
            "peg_table": self.table in peg_partners,
            "socket_table": self.table in socket_partners,
            "peg_socket": bool(peg_partners & self.socket),
            "peg_pin": pin_peg,
        }

    def __call__(self, data: mujoco.MjData) -> int:
        c = self.contacts(data)
        if not (c["right_peg"] and c["left_socket"]):
            return 0
        if c["peg_table"] or c["socket_table"]:
            return 1
        if not c["peg_socket"]:
            return 2
        return 4 if c["peg_pin"] else 3


class InsertionTask(BimanualTask):
    """Insert the peg (right arm) into the socket (left arm), both held above the table.
    Sparse reward 0-4 (``InsertionReward``); success = 4.

    Observations: ``qpos`` (16), ``qvel`` (16), ``env_state`` (14: peg pose then socket
    pose, [xyz m, quat wxyz] each) and ``env_vel`` (12).
    """

    name: ClassVar[str] = "sim_insertion"
    objects: ClassVar[tuple[str, ...]] = ("peg", "socket")
    max_reward: ClassVar[float] = MAX_REWARD

    def __init__(self, scene, config):
        super().__init__(scene, config)
        self.reward_fn = InsertionReward(scene.model)

    def get_reward(self) -> int:
        """Sparse 0-4 (see ``InsertionReward``)."""
        return self.reward_fn(self.data)

    def get_task_description(self) -> str:
        """The insertion in words (the same for every episode)."""
        return (
            "pick up the blue socket with the left arm and the red peg with the right arm, "
            "lift both and insert the peg into the socket"
        )


class InsertionSampler(BimanualSampler):
    """Arms at ``START_ARM_POSE``; peg and socket resting at ``sample_insertion_poses(rng)``."""

    task_cls = InsertionTask

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return {"peg": ("peg_joint", PEG_GEOM), "socket": ("socket_joint", "socket-1")}

    def _sample_task(self, scene: Scene) -> InsertionTask:
        peg, socket = sample_insertion_poses(self.rng)
        scene.objects["peg"].set_pose(scene.data, peg)
        scene.objects["socket"].set_pose(scene.data, socket)
        return self.task_cls(scene, self.config)


#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "sim_insertion",
        InsertionTask,
        InsertionSampler,
        "insertion",
        "Stationary AI: insert a peg (right arm) into a socket (left arm) above the table",
        policy="trossen_arm_mujoco.policies.insertion:InsertionPolicy",
        aliases=("insertion",),
        record=record_defaults(400),
        # 2 both objects grasped and lifted, 3 peg touches socket, 4 peg touches the pin
        stages={"grasped": 2.0, "contact": 3.0, "inserted": 4.0},
        gym_ids={"TrossenMujoco/StationaryAIInsertion-v0": "env"},
        # the peg's and socket's spawn regions with their lengths and the lift to where they
        # meet (x -0.05..0.10 m, y -0.26..0.23 m, z up to 0.25 m): rows 202-310, columns
        # 215-447 of cam_high
        camera_crop="cam_high:170,211,180,240",
        # the arms move from the first frame: without these the pose encoder read the arms,
        # not the peg (23.5 mm off at the start against 1.6 mm; docs Benchmarks, 2026-11-29)
        pose_static_frames=1000,
        required=("ee_scene", "max_object_velocity"),
    ),
)
