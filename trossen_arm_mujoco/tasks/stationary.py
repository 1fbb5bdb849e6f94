"""dm_control task base for the Stationary AI kit, shared by the EE and joint front doors.

It configures the layers (robot config, cameras, cube object, reward) over the dm_control
``Physics`` it is handed; ``ee_sim_env.py`` and ``sim_env.py`` choose the flavour.
"""

from __future__ import annotations

import collections
from collections.abc import Sequence

import mujoco
import numpy as np
from dm_control.mujoco.engine import Physics
from dm_control.suite import base
from dm_env import specs

from trossen_arm_mujoco.constants import DT, STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.sim.env import MujocoEnv
from trossen_arm_mujoco.tasks.transfer_cube import TransferCubeReward

LAYOUT_GROUPS = ("left_arm", "left_gripper", "right_arm", "right_gripper")


class StationaryTaskBase(base.Task):
    """Common part of ``TrossenAIStationaryEETask`` and ``TrossenAIStationaryTask``.

    Args:
        random: int seed or ``np.random.Generator`` for this task's randomization.
        onscreen_render: accepted for compatibility (display is done by the scripts).
        cam_list: cameras to render into observations; None = all four, [] = none.
        image_size: (height, width) of rendered images.
    """

    DEFAULT_XML = ""

    def __init__(
        self,
        random: int | np.random.Generator | None = None,
        onscreen_render: bool = False,
        cam_list: Sequence[str] | None = None,
        image_size: tuple[int, int] = (480, 640),
    ):
        if isinstance(random, np.random.Generator):
            self.rng = random
            super().__init__(random=int(random.integers(2**31)))
        else:
            super().__init__(random=random)
            self.rng = np.random.default_rng(random)
        self.onscreen_render = onscreen_render
        self.cam_list = list(STATIONARY_CAMERAS if cam_list is None else cam_list)
        self.image_size = tuple(image_size)
        #: Render camera images into observations (the recorder turns it off for steps whose
        #: observation is not stored).
        self.render_enabled = True
        self._scene: MujocoEnv | None = None
        self._scene_physics: Physics | None = None
        self._reward: TransferCubeReward | None = None
        self._reward_model = None

    # -- layers -------------------------------------------------------------------------
    def robot_config(self) -> RobotConfig:
        raise NotImplementedError

    def scene(self, physics: Physics) -> MujocoEnv:
        """The layered world over ``physics``, built once per physics (names looked up once)."""
        if self._scene is None or self._scene_physics is not physics:
            if self._scene is not None:
                self._scene.close()
            self._scene = MujocoEnv(
                physics=physics,
                robots={"stationary_ai": self.robot_config()},
                objects={"box": ("red_box_joint", "red_box")},
                camera_names=self.cam_list,
                height=self.image_size[0],
                width=self.image_size[1],
                ctrl_dt=DT,
            )
            self._scene_physics = physics
            self._layout = self._scene.robots["stationary_ai"].view.qpos_indices(LAYOUT_GROUPS)
        return self._scene

    def robot(self, physics: Physics):
        return self.scene(physics).robots["stationary_ai"]

    def transfer_reward(self, physics: Physics) -> int:
        """The transfer-cube reward (0-4), see ``tasks.transfer_cube``."""
        if self._reward is None or self._reward_model is not physics.model.ptr:
            self._reward = TransferCubeReward(physics.model.ptr)
            self._reward_model = physics.model.ptr
        return self._reward(physics.data.ptr)

    def close(self) -> None:
        if self._scene is not None:
            self._scene.close()

    # -- dm_control hooks ---------------------------------------------------------------
    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        low, high = self.action_bounds(physics)
        return specs.BoundedArray((16,), np.float64, low, high, name="action")

    def action_bounds(self, physics: Physics) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def initialize_robots(self, physics: Physics) -> None:
        """Arms at ``START_ARM_POSE`` at rest; controls (and mocap bodies) hold that pose."""
        self.robot(physics).reset(physics.data.ptr)

    def initialize_episode(self, physics: Physics) -> None:
        """Finish episode setup: every control holds the state the subclass has set."""
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        self.robot(physics).hold(physics.data.ptr)
        super().initialize_episode(physics)

    def split_action(self, action: np.ndarray) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def before_step(self, action, physics: Physics) -> None:
        a = np.asarray(action, dtype=float).reshape(-1)
        if a.shape != (16,):
            raise UserError(f"action must have 16 values, got {a.size}")
        if not np.all(np.isfinite(a)):
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        robot = self.robot(physics)
        robot.update_control(self.split_action(a))
        robot.compute_control(physics.data.ptr)

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """qpos (16), qvel (16), env_state, images (requested cameras), mocap_pose_left/right
        (7 each, tool-frame target [xyz, quat wxyz]), gripper_ctrl (2, m)."""
        scene = self.scene(physics)
        data = physics.data.ptr
        view = scene.robots["stationary_ai"].view
        obs: collections.OrderedDict = collections.OrderedDict()
        obs["qpos"] = data.qpos[self._layout].copy()
        obs["qvel"] = data.qvel[self._layout].copy()
        obs["env_state"] = self.get_env_state(physics)
        obs["images"] = scene.render_images() if self.render_enabled else {}
        obs["mocap_pose_left"] = self.tool_target(physics, "left_arm")
        obs["mocap_pose_right"] = self.tool_target(physics, "right_arm")
        obs["gripper_ctrl"] = np.concatenate(
            [view.group("left_gripper").get_ctrl(data), view.group("right_gripper").get_ctrl(data)]
        )
        return obs

    def tool_target(self, physics: Physics, arm: str) -> np.ndarray:
        raise NotImplementedError

    def get_env_state(self, physics: Physics) -> np.ndarray:
        raise NotImplementedError

    def get_reward(self, physics: Physics) -> float:
        raise NotImplementedError
