"""Mobile pick and place (Mobile AI): drive to the table, pick the cube with the left arm,
place it on the target.

Scene ``mobile_ai/mobile_ai_scene.xml``: table top at z = 0.75 m, a 50 mm cube
(``cube_joint``) and the place target (site ``target_site``); the base starts at a random
pose behind the table, the cube at a random spot on it. Reward stages (``STAGES``): 1 the
base is at the table, 2 the left fingers touch the cube, 3 the cube is lifted ``lift_height``,
4 it rests within ``success_tolerance`` of the target, untouched (success). Observations are
float64, world frame; recorded in the ``mobileai`` layout (the arms' 14 values, then the
base's [x.vel m/s, theta.vel rad/s]). Actions: arms in joint position, the base in
``base_velocity``. Scripted policy: ``policies/mobile_pick_place.py``.

Docs: docs/concepts/models.md (The mobile pick-and-place task),
docs/gym/MobileAIPickPlace-v0.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.assets import MOBILE_AI_CAMERAS
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.configs import RobotConfig, mobile_ai_config
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, SIDES
from trossen_arm_mujoco.sim.contacts import ContactPartners
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.bimanual import finger_geoms
from trossen_arm_mujoco.tasks.config_key import Key, number, positive, region
from trossen_arm_mujoco.tasks.observation import Part, indexed
from trossen_arm_mujoco.tasks.sampler import TaskSampler, uniform
from trossen_arm_mujoco.tasks.task import Task
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

__all__ = ["ARM_GROUPS", "STAGES", "TASKS", "MobilePickPlaceSampler", "MobilePickPlaceTask"]

#: Move groups of the 14 arm values, in the real kit's order (left arm, left gripper, right ...).
ARM_GROUPS = tuple(g for side in SIDES for g in (f"{side}_arm", f"{side}_gripper"))
#: Reward levels (eval's stages): the reward that marks each.
STAGES = {"at_table": 1.0, "touched": 2.0, "lifted": 3.0, "placed": 4.0}
CUBE_HALF_SIZE = 0.025
#: How far (rad, m) a joint may pass its range under load (its observation bounds allow it).
LIMIT_SLACK = 0.01
#: Most the base may be away from the world origin (m) and its speed (m/s, rad/s): bounds.
BASE_RANGE, BASE_SPEED = 3.0, 2.0


class MobilePickPlaceTask(Task):
    """Drive to the table, pick the cube with the left arm, place it on the target.
    Sparse reward 0-4 (module docstring); success = 4."""

    name: ClassVar[str] = "mobile_pick_place"
    robot_name: ClassVar[str] = "mobile_ai"
    max_reward: ClassVar[float] = 4.0
    #: the free objects of ``env_state``, in order (as the Stationary AI tasks name theirs)
    objects: ClassVar[tuple[str, ...]] = ("cube",)

    def __init__(self, scene: Scene, config: Mapping[str, Any]):
        super().__init__(scene, config)
        model, view = scene.model, self.robot.view
        self.base = view.get_move_group("base")
        self.cube = scene.objects["cube"]
        self.layout = view.qpos_indices(ARM_GROUPS)
        self.layout_dofs = view.dof_indices(ARM_GROUPS)
        ranges = np.concatenate([view.get_move_group(g).joint_range for g in ARM_GROUPS])
        # bounds: the joint ranges widened by what the soft limits let a joint pass them
        self.qpos_low, self.qpos_high = ranges[:, 0] - LIMIT_SLACK, ranges[:, 1] + LIMIT_SLACK
        self.base_qpos = self.base.qpos_idx[:7]  # the free joint: [xyz m, quat wxyz]
        self.base_qvel = self.base.dof_idx[:6]  # [linear m/s (world), angular rad/s (body)]
        self.target = model.site_pos[lookup_id(model, "site", "target_site")]  # world frame
        self.table_top = float(self.config["table_height"])
        self.rest_z = self.table_top + CUBE_HALF_SIZE
        self.tolerance = float(self.config["success_tolerance"])
        self.lift_height = float(self.config["lift_height"])
        self.reach_distance = float(self.config["reach_distance"])
        self.shoulder = lookup_id(model, "body", "left/base_link")
        self.table = lookup_id(model, "geom", "table")
        self.fingers = finger_geoms(model, "left") | finger_geoms(model, "right")
        self.left_fingers = finger_geoms(model, "left")
        self._partners = ContactPartners(model, [lookup_id(model, "geom", "cube")])
        self.max_qvel = float(self.config["max_joint_velocity"])
        self.ws_low = np.asarray(self.config["workspace_low"], dtype=float)
        self.ws_high = np.asarray(self.config["workspace_high"], dtype=float)

    # -- observation ------------------------------------------------------------------------
    def observation_parts(self) -> list[Part]:
        """``qpos`` (16,), ``qvel`` (16,), ``base_pose`` (7,), ``base_vel`` (6,),
        ``env_state`` (7,), ``target`` (3,), live views: see the module docstring."""
        data, v, n = self.data, self.max_qvel, len(self.layout)
        pose_low = np.concatenate([self.ws_low, -np.ones(4)])
        pose_high = np.concatenate([self.ws_high, np.ones(4)])
        r, s = BASE_RANGE, BASE_SPEED
        return [
            Part("qpos", indexed(data.qpos, self.layout), self.qpos_low, self.qpos_high),
            Part("qvel", indexed(data.qvel, self.layout_dofs), np.full(n, -v), np.full(n, v)),
            Part(
                "base_pose",
                indexed(data.qpos, self.base_qpos),
                [-r, -r, 0.0, -1, -1, -1, -1],
                [r, r, 1.0, 1, 1, 1, 1],
            ),
            Part("base_vel", indexed(data.qvel, self.base_qvel), np.full(6, -s), np.full(6, s)),
            Part("env_state", self.cube.pose_view(data), pose_low, pose_high),
            Part("target", self.target, self.ws_low, self.ws_high),
        ]

    def recorded_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(state, velocity) as recorded, (16,) each in the ``mobileai`` layout
        (``robot.layout.MOBILEAI_LAYOUT``): the arms' 14 positions in the real kit's layout
        (rad / m) then the base's measured [x.vel m/s, theta.vel rad/s]; the arms' 14
        velocities then the same base velocities."""
        kit = KIT14_LAYOUT.vendor_index
        base = self.base.get_base_velocity(self.data)
        return (
            np.concatenate([self.data.qpos[self.layout[kit]], base]),
            np.concatenate([self.data.qvel[self.layout_dofs[kit]], base]),
        )

    # -- scoring ----------------------------------------------------------------------------
    def touching(self) -> tuple[bool, bool, bool]:
        """(left fingers touch the cube, any finger touches it, it touches the table)."""
        partners = self._partners(self.data)
        return (
            bool(partners & self.left_fingers),
            bool(partners & self.fingers),
            self.table in partners,
        )

    def left_touches_object(self) -> bool:
        """The left fingers touch the cube (eval's rollout analysis reads it)."""
        return self.touching()[0]

    def at_table(self) -> bool:
        """The cube is within ``reach_distance`` (m, horizontally) of the left shoulder."""
        cube = self.cube.pose_view(self.data)[:2]
        return bool(np.hypot(*(cube - self.data.xpos[self.shoulder][:2])) <= self.reach_distance)

    def placed(self) -> bool:
        """The cube rests on the table within ``success_tolerance`` of the target, free."""
        pos = self.cube.pose_view(self.data)[:3]
        _, held, on_table = self.touching()
        near = np.hypot(*(pos[:2] - self.target[:2])) <= self.tolerance
        return bool(near and on_table and not held and abs(pos[2] - self.rest_z) < 0.005)

    def get_reward(self) -> int:
        """0-4: 4 placed, 3 lifted by the left fingers, 2 touched by them, 1 at the table."""
        if self.placed():
            return 4
        left, _, on_table = self.touching()
        lifted = self.cube.pose_view(self.data)[2] >= self.rest_z + self.lift_height
        if left and lifted and not on_table:
            return 3
        if left:
            return 2
        return 1 if self.at_table() else 0

    def judge_success(self) -> bool:
        """The reward is 4 (placed)."""
        return self.current_reward() >= self.max_reward

    def get_task_description(self) -> str:
        """The task in words (the same for every episode)."""
        return (
            "drive to the table, pick up the red cube with the left arm and place it on the target"
        )


class MobilePickPlaceSampler(TaskSampler):
    """The Mobile AI at its home arm pose; the base at a uniform start pose in
    [base_start_low, base_start_high] (x, y, yaw); the cube uniform in [cube_low, cube_high]
    (x, y) resting on the table."""

    task_cls = MobilePickPlaceTask
    robot_name: ClassVar[str] = "mobile_ai"
    arms: ClassVar[tuple[tuple[str, str], ...]] = (
        ("left_arm", "left_gripper"),
        ("right_arm", "right_gripper"),
    )
    cameras: ClassVar[tuple[str, ...]] = tuple(MOBILE_AI_CAMERAS)

    def robot_config(self) -> RobotConfig:
        return mobile_ai_config()

    def objects(self) -> dict[str, tuple[str, str | None]]:
        return {"cube": ("cube_joint", "cube")}

    def _sample_task(self, scene: Scene) -> MobilePickPlaceTask:
        x, y, yaw = uniform(self.rng, self.config["base_start_low"], self.config["base_start_high"])
        self.robot_view.get_move_group("base").set_planar_pose(scene.data, x, y, yaw)
        cx, cy = uniform(self.rng, self.config["cube_low"], self.config["cube_high"])
        rest = float(self.config["table_height"]) + CUBE_HALF_SIZE
        scene.objects["cube"].set_pose(scene.data, [cx, cy, rest, 1.0, 0.0, 0.0, 0.0])
        return self.task_cls(scene, self.config)


#: The task's declaration (``tasks.task_entry``): what every front door derives from.
TASKS = (
    TaskEntry(
        "mobile_pick_place",
        MobilePickPlaceTask,
        MobilePickPlaceSampler,
        "mobile_pick_place",
        "Mobile AI: drive to the table, pick a cube with the left arm and place it",
        policy="trossen_arm_mujoco.policies.mobile_pick_place:MobilePickPlacePolicy",
        record=record_defaults(750, MOBILE_AI_CAMERAS),
        stages=STAGES,
        gym_ids={"TrossenMujoco/MobileAIPickPlace-v0": "env"},
        keys={
            **region("base_start", 3, low=-3.0, high=3.0, unit="m, m, rad"),
            **region("cube", 2),
            "success_tolerance": positive(1.0, "m"),
            "lift_height": number(0.0, 1.0, "m"),
            "reach_distance": Key("number", 0.0, 2.0, True, unit="m"),
        },
        required=(
            "base_start_low",
            "base_start_high",
            "cube_low",
            "cube_high",
            "success_tolerance",
            "lift_height",
            "reach_distance",
        ),
    ),
)
