"""Lift the puck: the Stationary AI kit's right arm picks a blue puck off the table.

Everything trossen_arm_mujoco needs to know about the task is here: the scene object (an
MJCF fragment composed into the kit's shipped scene at load time), the sampler (where the
puck starts), the reward with its stages, success, the config with its own keys, the
scripted policy (``policy.py``) and the gym id, gathered in ``TASK``.

Units: m, rad, s; world frame = the kit's (table top at z = 0.02).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.sim.contacts import ContactPartners
from trossen_arm_mujoco.tasks.bimanual import BimanualSampler, BimanualTask, finger_geoms
from trossen_arm_mujoco.tasks.config_key import Key
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

TABLE_TOP_Z = 0.02
PUCK_RADIUS = 0.015
PUCK_HALF_HEIGHT = 0.0125

#: The scene object: a free body added to the kit's scene when the task loads it.
PUCK_MJCF = f"""
<asset><material name="puck_blue" rgba="0.1 0.3 0.9 1"/></asset>
<body name="puck" pos="0 -0.05 {TABLE_TOP_Z + PUCK_HALF_HEIGHT}">
  <freejoint name="puck_joint"/>
  <geom name="puck" type="cylinder" size="{PUCK_RADIUS} {PUCK_HALF_HEIGHT}" mass="0.03"
        condim="4" friction="1.5 0.02 0.0001" material="puck_blue"/>
</body>
"""

#: Reward levels (the stages eval reports): 1 the right fingers touch the puck, 2 and it is
#: off the table. Success = 2.
STAGES = {"touched": 1.0, "lifted": 2.0}


class LiftPuckReward:
    """0 nothing, 1 the right fingers touch the puck, 2 they touch it and it is off the
    table. Geom ids are looked up once here; a call only scans ``data.contact``."""

    def __init__(self, model):
        self.table = lookup_id(model, "geom", "table")
        self.right = finger_geoms(model, "right")
        self._partners = ContactPartners(model, [lookup_id(model, "geom", "puck")])

    def __call__(self, data) -> int:
        partners = self._partners(data)
        touched = bool(partners & self.right)
        if touched and self.table not in partners:
            return 2
        return 1 if touched else 0


class LiftPuck(BimanualTask):
    """Lift the puck with the right gripper. Sparse reward 0-2; success = 2."""

    name: ClassVar[str] = "lift_puck"
    objects: ClassVar[tuple[str, ...]] = ("puck",)  # env_state order
    max_reward: ClassVar[float] = 2.0

    def __init__(self, scene, config):
        super().__init__(scene, config)
        self.reward_fn = LiftPuckReward(scene.model)

    def get_reward(self) -> int:
        return self.reward_fn(self.data)

    def get_task_description(self) -> str:
        return "lift the blue puck off the table with the right arm"


class LiftPuckSampler(BimanualSampler):
    """The kit at its home pose, the shipped cube removed, the puck uniform in
    [puck_low, puck_high] (x, y) on the table."""

    task_cls = LiftPuck
    scene_objects = (PUCK_MJCF,)
    removed_objects = ("box",)

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return {"puck": ("puck_joint", "puck")}

    def _sample_task(self, scene) -> LiftPuck:
        xy = self.rng.uniform(self.config["puck_low"], self.config["puck_high"])
        pose = np.array([xy[0], xy[1], TABLE_TOP_Z + PUCK_HALF_HEIGHT, 1.0, 0.0, 0.0, 0.0])
        scene.objects["puck"].set_pose(scene.data, pose)
        return self.task_cls(scene, self.config)


#: The task's config: the kit's timing and bounds, and two keys of its own.
CONFIG = {
    "scene": "stationary_ai/trossen_ai_scene_joint.xml",
    "ee_scene": "stationary_ai/trossen_ai_scene.xml",
    "policy_dt": 0.02,
    "ctrl_dt": 0.02,
    "sim_dt": 0.002,
    "max_episode_steps": 250,
    "ee_delta_limit": 0.03,
    "joint_rel_limit": 0.1,
    "table_height": 0.02,
    "safety_margin": 0.01,
    "workspace_low": [-0.8, -0.8, -0.1],
    "workspace_high": [0.8, 0.8, 0.9],
    "max_joint_velocity": 20.0,
    "max_object_velocity": 5.0,
    "puck_low": [-0.08, -0.15],
    "puck_high": [0.08, 0.0],
}

TASK = TaskEntry(
    name="lift_puck",
    task=LiftPuck,
    sampler=LiftPuckSampler,
    config=CONFIG,
    description="Stationary AI: lift a blue puck off the table with the right arm",
    policy="my_trossen_task.policy:LiftPuckPolicy",
    record=record_defaults(250),
    stages=STAGES,
    gym_ids={"MyTrossen/LiftPuck-v0": "env"},
    keys={
        "puck_low": Key("vector", -0.5, 0.5, lengths=(2,), unit="m"),
        "puck_high": Key("vector", -0.5, 0.5, lengths=(2,), unit="m"),
    },
    required=("puck_low", "puck_high"),
)
