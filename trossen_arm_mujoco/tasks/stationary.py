"""dm_control task bases for the Stationary AI kit: the documented customization API.

``TrossenAIStationaryEETask`` (mocap arms, 16-value EE action) and ``TrossenAIStationaryTask``
(14 joint actuators; joint action of 16 values in the qpos layout or 14 in the real kit's
layout, as LeRobot policies trained on the kit give) configure the layers (robot
config, cameras, objects) over the dm_control ``Physics`` they are handed; dm_control steps.
A custom task subclasses one of them and overrides ``initialize_episode(physics)``,
``get_env_state(physics)`` and ``get_reward(physics)``. Registered tasks are served by the
adapters in ``tasks/dm_tasks.py``; ``ee_sim_env.py`` and ``sim_env.py`` re-export all of them.

Docs: docs/reference/dm-control-envs.md, docs/writing-a-task.md.
"""

from __future__ import annotations

import collections
from collections.abc import Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np
from dm_control.suite import base
from dm_env import specs

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS, STATIONARY_TABLE_TOP
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import (
    RobotConfig,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
)
from trossen_arm_mujoco.robot.layout import (
    EE_LAYOUT,
    GRIPPER_OPEN,
    KIT14_LAYOUT,
    VENDOR16_LAYOUT,
    kit_joint_commands,
)
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks.bimanual import LAYOUT_GROUPS, ROBOT_NAME
from trossen_arm_mujoco.tasks.task import DEFAULT_POLICY_DT

__all__ = [
    "CUBE_OBJECTS",
    "StationaryTaskBase",
    "TrossenAIStationaryEETask",
    "TrossenAIStationaryTask",
]

#: Objects of the cube scenes, for custom tasks on them: name -> (free joint, geom).
CUBE_OBJECTS = {"box": ("red_box_joint", "red_box")}


class StationaryTaskBase(base.Task):
    """Common part of ``TrossenAIStationaryEETask`` and ``TrossenAIStationaryTask``.

    Args:
        random: int seed or ``np.random.Generator``: this task's one source of randomness.
        onscreen_render: accepted for compatibility (display is done by the scripts).
        cam_list: cameras rendered into every observation; None = all four, [] = none (then
            no GL context is ever opened).
        image_size: (height, width) of rendered images.
    """

    DEFAULT_XML: ClassVar[str] = ""
    FLAVOUR: ClassVar[str] = ""

    def __init__(
        self,
        random: int | np.random.Generator | None = None,
        onscreen_render: bool = False,
        cam_list: Sequence[str] | None = None,
        image_size: tuple[int, int] = (480, 640),
    ):
        self.rng = random if isinstance(random, np.random.Generator) else None
        if self.rng is None:
            self.rng = np.random.default_rng(random)
        # dm_control's own RandomState is unused by these tasks; seed it from our generator.
        super().__init__(random=int(self.rng.integers(2**31)))
        self.onscreen_render = onscreen_render
        self.cam_list = list(STATIONARY_CAMERAS if cam_list is None else cam_list)
        self.image_size = tuple(image_size)
        self._scene: Scene | None = None
        self._scene_physics: Any = None

    # -- layers -------------------------------------------------------------------------
    def robot_config(self) -> RobotConfig:
        """Robot config of this flavour (joint or mocap Stationary AI); subclasses return theirs."""
        raise NotImplementedError

    def build_scene(self, physics) -> Scene:
        """The layered world over ``physics`` (custom tasks: the cube scenes' objects)."""
        return Scene(
            physics=physics,
            robots={ROBOT_NAME: self.robot_config()},
            objects=CUBE_OBJECTS if _has_joint(physics, "red_box_joint") else {},
            camera_names=self.cam_list,
            height=self.image_size[0],
            width=self.image_size[1],
            ctrl_dt=DEFAULT_POLICY_DT,
            table_height=STATIONARY_TABLE_TOP,
        )

    def scene(self, physics) -> Scene:
        """The layered world over ``physics``, built once per physics (names looked up once)."""
        if self._scene is None or self._scene_physics is not physics:
            if self._scene is not None:
                self._scene.close()
            self._scene = self.build_scene(physics)
            self._scene_physics = physics
            self._layout = self._scene.robots[ROBOT_NAME].view.qpos_indices(LAYOUT_GROUPS)
        return self._scene

    def robot(self, physics):
        """The Stationary AI ``Robot`` of ``physics``'s scene."""
        return self.scene(physics).robots[ROBOT_NAME]

    def close(self) -> None:
        """Close the scene (renderers) built over the physics, if any."""
        if self._scene is not None:
            self._scene.close()

    # -- dm_control hooks ---------------------------------------------------------------
    def action_spec(self, physics) -> specs.BoundedArray:
        low, high = self.action_bounds(physics)
        return specs.BoundedArray((16,), np.float64, low, high, name="action")

    def action_bounds(self, physics) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the 16-value action, two (16,) arrays in the action's units."""
        raise NotImplementedError

    def initialize_robots(self, physics) -> None:
        """Arms at ``START_ARM_POSE`` at rest; controls (and mocap bodies) hold that pose."""
        self.robot(physics).reset(physics.data.ptr)

    def initialize_episode(self, physics) -> None:
        """Finish episode setup: every control holds the state the subclass has set."""
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        self.robot(physics).hold(physics.data.ptr)
        super().initialize_episode(physics)

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """The 16-value action as move group id -> command."""
        raise NotImplementedError

    def check_action_size(self, size: int) -> None:
        """UserError unless an action of ``size`` values fits this task (16)."""
        if size != 16:
            raise UserError(f"action must have 16 values, got {size}")

    def before_step(self, action, physics) -> None:
        a = np.asarray(action, dtype=float).reshape(-1)
        self.check_action_size(a.size)
        if not np.all(np.isfinite(a)):
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        robot = self.robot(physics)
        robot.update_control(self.split_action(a))
        robot.compute_control(physics.data.ptr)

    def get_observation(self, physics) -> collections.OrderedDict:
        """qpos (16), qvel (16), env_state, images (requested cameras), mocap_pose_left/right
        (7 each, tool-frame target [xyz, quat wxyz]), gripper_ctrl (2, m)."""
        scene = self.scene(physics)
        data = physics.data.ptr
        view = scene.robots[ROBOT_NAME].view
        obs: collections.OrderedDict = collections.OrderedDict()
        obs["qpos"] = data.qpos[self._layout].copy()
        obs["qvel"] = data.qvel[self._layout].copy()
        obs["env_state"] = self.get_env_state(physics)
        obs["images"] = scene.render_images()
        obs["mocap_pose_left"] = self.tool_target(physics, "left_arm")
        obs["mocap_pose_right"] = self.tool_target(physics, "right_arm")
        obs["gripper_ctrl"] = np.concatenate(
            [
                view.get_move_group("left_gripper").get_ctrl(data),
                view.get_move_group("right_gripper").get_ctrl(data),
            ]
        )
        return obs

    def tool_target(self, physics, arm: str) -> np.ndarray:
        """The tool target of ``arm`` now, (7,) [xyz m, quat wxyz] in the world frame
        (the ``mocap_pose_left/right`` observations)."""
        raise NotImplementedError

    def get_env_state(self, physics) -> np.ndarray:
        """The state of the task's objects (e.g. the cube's 7-value pose); subclasses say which."""
        raise NotImplementedError

    def get_reward(self, physics) -> float:
        raise NotImplementedError


def _has_joint(physics, name: str) -> bool:
    return mujoco.mj_name2id(physics.model.ptr, mujoco.mjtObj.mjOBJ_JOINT, name) >= 0


class TrossenAIStationaryEETask(StationaryTaskBase):
    """Bimanual task with mocap-driven arms (scene ``stationary_ai/trossen_ai_scene.xml``).

    Action (16): ``[left xyz (m), left quat wxyz, left gripper (m), right ...]``, world frame
    (``robot.layout.EE_LAYOUT``). Subclass it and override ``initialize_episode(physics)``
    (call ``self.initialize_robots(physics)`` first and ``super().initialize_episode(physics)``
    last), ``get_env_state(physics)`` and ``get_reward(physics)``.
    """

    DEFAULT_XML = "stationary_ai/trossen_ai_scene.xml"
    FLAVOUR = "ee"

    def robot_config(self) -> RobotConfig:
        return stationary_ai_mocap_config()

    def action_bounds(self, physics):
        """(low, high) of the mocap action per arm: tool position x, y in [-1, 1] m,
        z in [0, 1.5] m, quaternion components in [-1, 1], gripper opening in [0, 0.044] m."""
        pose_low = [-1.0, -1.0, 0.0, -1, -1, -1, -1]
        pose_high = [1.0, 1.0, 1.5, 1, 1, 1, 1]
        low = np.array(pose_low + [0.0] + pose_low + [0.0])
        high = np.array(pose_high + [GRIPPER_OPEN] + pose_high + [GRIPPER_OPEN])
        return low, high

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        return EE_LAYOUT.commands(action)

    def tool_target(self, physics, arm: str) -> np.ndarray:
        """The mocap pose commanded to ``arm`` ([xyz, quat wxyz], world)."""
        return self.robot(physics).view.get_move_group(arm).get_ctrl(physics.data.ptr)


class TrossenAIStationaryTask(StationaryTaskBase):
    """Bimanual task with joint position actuators (scene ``trossen_ai_scene_joint.xml``).

    Action (16) in the qpos layout (``robot.layout.VENDOR16_LAYOUT``): each arm's 6 joints and its
    gripper (the actuated finger value, index 7 / 15) go to position actuators; the coupled
    finger values (index 6 / 14) are not commanded separately. An action of 14 values in the
    real kit's layout (``robot.layout.KIT14_LAYOUT``: per arm 6 joints, then the gripper,
    index 6 / 13) gives the same commands. ``action_spec()`` describes the 16. Subclass it
    and override
    ``initialize_episode(physics)`` (e.g. inside ``physics.reset_context()`` set
    ``physics.named.data.qpos[:16] = START_ARM_POSE``, then call
    ``super().initialize_episode(physics)``), ``get_env_state`` and ``get_reward``.
    """

    DEFAULT_XML = "stationary_ai/trossen_ai_scene_joint.xml"
    FLAVOUR = "joint"

    def robot_config(self) -> RobotConfig:
        return stationary_ai_joint_config()

    def action_bounds(self, physics):
        """Joint limits in the qpos layout (rad / m)."""
        view = self.robot(physics).view
        ranges = np.concatenate([view.get_move_group(g).joint_range for g in LAYOUT_GROUPS])
        return ranges[:, 0].copy(), ranges[:, 1].copy()

    def check_action_size(self, size: int) -> None:
        """UserError unless ``size`` is 14 (the real kit's layout) or 16 (the qpos layout)."""
        if size not in (KIT14_LAYOUT.size, VENDOR16_LAYOUT.size):
            raise UserError(
                f"action must have {KIT14_LAYOUT.size} values (the real kit's layout) or "
                f"{VENDOR16_LAYOUT.size} (the qpos layout), got {size}"
            )

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        """Robot commands of a 14- or 16-value joint action."""
        a = np.asarray(action, dtype=float).reshape(-1)
        self.check_action_size(a.size)
        return kit_joint_commands(a)

    def tool_target(self, physics, arm: str) -> np.ndarray:
        """The arm's current tool-frame (ee_site) pose [xyz, quat wxyz], world frame."""
        return self.robot(physics).view.get_move_group(arm).get_frame_pose(physics.data.ptr)
