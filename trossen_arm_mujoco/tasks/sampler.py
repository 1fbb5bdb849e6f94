"""TaskSampler: owns the env of a task family and turns a seed into a ready episode.

It is the only place where episodes are randomized; every random number comes from the
``np.random.Generator`` given to (or made from the seed of) ``sample_task``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.assets import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.controllers import EEDeltaController
from trossen_arm_mujoco.sim.env import MujocoEnv
from trossen_arm_mujoco.tasks.task import Task

Seed = int | np.random.Generator | None

#: Flavours of a scene: joint position actuators, or mocap-driven arms (bimanual tasks).
FLAVOURS: tuple[str, ...] = ("joint", "ee")


def as_generator(seed: Seed) -> np.random.Generator:
    """The generator itself, or a new one seeded with ``seed`` (None: fresh entropy)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))):
        raise UserError(f"seed must be an int or a numpy Generator, got {type(seed).__name__}")
    return np.random.default_rng(seed)


class TaskSampler:
    """Base of every sampler.

    Args:
        config: task config (``tasks.config.load_task_config``); ``scene`` (path relative to
            the assets folder) and ``ctrl_dt`` are read here.
        command_mode: command mode of the arms (``joint_position``, ``joint_rel_position``,
            ``ee_delta``); grippers always take ``joint_position``.
        camera_names, height, width: cameras rendered by ``env.render_images()``.
        flavour: ``"joint"`` (scene ``config["scene"]``, arms in ``command_mode``) or ``"ee"``
            (scene ``config["ee_scene"]``, mocap-driven arms taking tool poses; bimanual
            tasks only).
        physics: an existing dm_control ``Physics`` of that scene to build the env over (the
            dm_control front doors); default: load the scene.

    Subclasses set ``task_cls``, ``robot_name``, ``arms`` and implement ``robot_config``,
    ``objects`` and ``randomize_scene``.
    """

    task_cls: ClassVar[type[Task]] = Task
    robot_name: ClassVar[str] = ""
    #: (arm group, gripper group) pairs, in action order.
    arms: ClassVar[tuple[tuple[str, str], ...]] = ()
    #: cameras of the scene offered for image observations; the first is the default.
    cameras: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        config: Mapping[str, Any],
        *,
        command_mode: str = "joint_position",
        camera_names: Sequence[str] = (),
        height: int = 480,
        width: int = 640,
        flavour: str = "joint",
        physics: Any = None,
    ):
        self.config = dict(config)
        self.command_mode = command_mode
        self.flavour = flavour
        if flavour == "joint":
            scene_key = "scene"
            robot = self.robot_config().with_command_modes(
                **{a: command_mode for a, _ in self.arms}
            )
        elif flavour == "ee":
            scene_key = "ee_scene"
            if "ee_scene" not in self.config:
                raise UserError(
                    f"task sampler {type(self).__name__} has no end-effector (mocap) flavour; "
                    "use flavour='joint'"
                )
            robot = self.ee_robot_config()
        else:
            raise unknown_name_error("flavour", flavour, FLAVOURS)
        self.env = MujocoEnv(
            None if physics is not None else Path(ASSETS_DIR) / self.config[scene_key],
            physics=physics,
            robots={self.robot_name: robot},
            objects=self.objects(),
            camera_names=camera_names,
            height=height,
            width=width,
            ctrl_dt=float(self.config["ctrl_dt"]),
        )
        if (
            flavour == "joint"
            and command_mode == "ee_delta"
            and self.config.get("hold_orientation", False)
        ):
            self._use_six_dof_ee_delta()
        self.task_cls(self.env, self.config)  # fail now on bad timing, not at the first reset

    def _use_six_dof_ee_delta(self) -> None:
        """Arms take 6-value ee_delta twists ([dx, dy, dz] m, rotation vector rad) so that the
        tool orientation can be held while moving."""
        robot = self.env.robots[self.robot_name]
        for arm, _ in self.arms:
            robot.controllers[arm] = EEDeltaController(
                robot.view.group(arm), self.env.model, rotation=True, ctrl_dt=self.env.ctrl_dt
            )

    # -- to override ----------------------------------------------------------------------
    def robot_config(self) -> RobotConfig:
        raise NotImplementedError

    def ee_robot_config(self) -> RobotConfig:
        """Robot config of the end-effector (mocap) flavour; only bimanual tasks have one."""
        raise UserError(f"task sampler {type(self).__name__} has no end-effector flavour")

    def objects(self) -> dict[str, tuple[str, str | None]]:
        """Free-joint objects of the scene: name -> (joint, geom)."""
        return {}

    def randomize_scene(self, rng: np.random.Generator) -> dict[str, Any]:
        """Randomize the freshly reset scene in place; return the task's episode parameters
        (keyword arguments of ``task_cls`` besides env and config)."""
        raise NotImplementedError

    # -- API ------------------------------------------------------------------------------
    def sample_task(self, seed: Seed = None, object_poses: Mapping[str, Any] | None = None) -> Task:
        """A ready task: env reset, scene randomized from ``seed``, task built and reset.

        Args:
            seed: int or ``np.random.Generator``; the only source of randomness.
            object_poses: object name -> pose [xyz, quat wxyz] placed after randomizing
                (e.g. to replay an episode from its recorded start).
        """
        rng = as_generator(seed)
        self.env.reset()
        task = self.start_episode(rng, object_poses)
        task.reset()
        return task

    def start_episode(
        self, rng: np.random.Generator, object_poses: Mapping[str, Any] | None = None
    ) -> Task:
        """Randomize the current scene from ``rng``, place ``object_poses``, build the task
        (not reset; the dm_control front doors reset through their own hooks)."""
        params = self.randomize_scene(rng)
        for name, pose in (object_poses or {}).items():
            if name not in self.env.objects:
                raise unknown_name_error("object", name, self.env.objects)
            self.env.objects[name].set_pose(self.env.data, np.asarray(pose, dtype=float))
        self.env.forward()
        return self.task_cls(self.env, self.config, **params)

    def make_task(self, **params: Any) -> Task:
        """A task over the current scene with explicit episode parameters (no reset)."""
        return self.task_cls(self.env, self.config, **params)

    def close(self) -> None:
        self.env.close()
