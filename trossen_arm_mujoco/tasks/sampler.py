"""TaskSampler: owns the scene of a task family and turns a seed into a ready episode.

It is the only place where episodes are randomized: every random number comes from
``self.rng`` (made from ``seed``, or replaced by the seed given to ``sample_task``). One
episode (``sample_task``): the scene is reset (positions only), the scene randomized (domain
randomization with ``randomize=True``; ``tasks.randomization``), the task's objects placed
and the task built (``_sample_task``; None when the draw gives no valid episode), then the
task reset. How the scene is built is one ``tasks.sampler_settings.SamplerSettings``; the
safety floor (``floor_margin`` above the config's ``table_height``) goes to the robot. The
sampler owns the scene and closes it (``close()``, or ``with``).

Docs: docs/writing-a-task.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.assets import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.controllers import EEDeltaController
from trossen_arm_mujoco.robot.robot_view import RobotView
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.sim.scene_edit import SceneEdit
from trossen_arm_mujoco.tasks.randomization import SceneRandomizer
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_KEY, default_randomization
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.task import Task

__all__ = ["MAX_SAMPLE_TRIES", "Seed", "TaskSampler", "as_generator", "uniform"]

#: ``sample_task`` attempts ``next_task`` makes before giving up.
MAX_SAMPLE_TRIES = 100

Seed = int | np.random.Generator | None


def uniform(rng: np.random.Generator, low: Any, high: Any, size: Any = None) -> Any:
    """``rng.uniform(low, high, size)``, the same draws as the arithmetic written out
    (``low + (high - low) * rng.random(shape)``), bit for bit; its cost is on
    docs/benchmarks.md (``benchmarks/numpy_paths.py``).

    Args:
        rng: the generator.
        low: lower bounds, a float or array-like (broadcast with ``high``).
        high: upper bounds, likewise.
        size: the output shape; None: the broadcast shape.

    Returns:
        A float when both bounds are scalars and ``size`` is None, else an array.
    """
    return rng.uniform(low, high, size)


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
        config: task config (``TaskEntry.load_config``); ``scene`` / ``ee_scene``
            (paths relative to the assets folder), ``ctrl_dt`` and ``sim_dt`` (when the config
            has it) are read here.
        settings: how the scene is built (``tasks.sampler_settings.SamplerSettings``: command
            mode, cameras and image size, flavour, randomization, looks, safety floor);
            default ``SamplerSettings()``.
        physics: an existing dm_control ``Physics`` of that scene to build the scene over (the
            dm_control front doors); default: load the scene.
        seed: int or ``np.random.Generator``: the sampler's generator ``self.rng``.

    Subclasses set ``task_cls``, ``robot_name``, ``arms`` (and ``scene_objects`` /
    ``removed_objects`` for objects of their own) and implement ``robot_config``,
    ``objects`` and ``_sample_task``.
    """

    task_cls: ClassVar[type[Task]] = Task
    robot_name: ClassVar[str] = ""
    #: (arm group, gripper group) pairs, in action order.
    arms: ClassVar[tuple[tuple[str, str], ...]] = ()
    #: cameras of the scene offered for image observations; the first is the default.
    cameras: ClassVar[tuple[str, ...]] = ()
    #: the task's own objects, composed into the config's scene at load time
    #: (``sim.scene_edit``): MJCF ``<body>`` fragments (text or file paths) ...
    scene_objects: ClassVar[tuple[str | Path, ...]] = ()
    #: ... and top-level bodies of that scene removed (e.g. the kit scene's ``box``).
    removed_objects: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        config: Mapping[str, Any],
        settings: SamplerSettings | None = None,
        *,
        physics: Any = None,
        seed: Seed = None,
    ):
        if settings is None:
            settings = SamplerSettings()
        elif not isinstance(settings, SamplerSettings):
            raise UserError(
                f"settings must be a SamplerSettings (tasks.sampler_settings), "
                f"got {type(settings).__name__}"
            )
        self.settings = settings
        self.config = dict(config)
        self.rng = as_generator(seed)
        self.randomize = settings.randomize
        #: record of the randomization of the current episode (None: nominal scene).
        self.randomization: dict[str, Any] | None = None
        self.command_mode = command_mode = settings.command_mode
        self.flavour = flavour = settings.flavour
        if flavour == "joint":
            scene_key = "scene"
            robot = self.robot_config().with_command_modes(
                **{a: command_mode for a, _ in self.arms}
            )
        else:
            scene_key = "ee_scene"
            if "ee_scene" not in self.config:
                raise UserError(
                    f"task sampler {type(self).__name__} has no end-effector (mocap) flavour; "
                    "use flavour='joint'"
                )
            robot = self.ee_robot_config()
        floor_margin = settings.floor_margin
        edit = self.scene_edit()  # a given physics was built with it (utils.make_sim_env)
        self.scene = Scene(
            None if physics is not None else Path(ASSETS_DIR) / self.config[scene_key],
            physics=physics,
            robots={self.robot_name: robot},
            objects=self.objects(),
            camera_names=settings.camera_names,
            height=settings.height,
            width=settings.width,
            ctrl_dt=float(self.config["ctrl_dt"]),
            sim_dt=self.config.get("sim_dt"),
            looks=settings.looks,
            table_height=None if floor_margin is None else self.config.get("table_height"),
            floor_margin=0.0 if floor_margin is None else floor_margin,
            edit=edit,
        )
        if (
            flavour == "joint"
            and command_mode == "ee_delta"
            and self.config.get("hold_orientation", False)
        ):
            self._use_six_dof_ee_delta()
        self.task_cls(self.scene, self.config)  # fail now on bad timing, not at the first reset
        self.randomizer = self._make_randomizer()

    def _use_six_dof_ee_delta(self) -> None:
        """Arms take 6-value ee_delta twists ([dx, dy, dz] m, rotation vector rad) so that the
        tool orientation can be held while moving."""
        robot = self.scene.robots[self.robot_name]
        for arm, _ in self.arms:
            robot.controllers[arm] = EEDeltaController(
                robot.view.get_move_group(arm),
                self.scene.model,
                rotation=True,
                ctrl_dt=self.scene.ctrl_dt,
            )

    def _make_randomizer(self) -> SceneRandomizer:
        view = self.robot_view
        arm_joints = [j for arm, _ in self.arms for j in view.get_move_group(arm).joint_ids]
        robot_joints = [j for g in view.move_groups.values() for j in g.joint_ids]
        return SceneRandomizer(
            self.scene.model,
            self.config.get(RANDOMIZATION_KEY) or default_randomization(),
            object_bodies=[o.body_id for o in self.scene.objects.values()],
            arm_joints=arm_joints,
            robot_joints=robot_joints,
        )

    @classmethod
    def scene_edit(cls) -> SceneEdit:
        """The task's own scene objects (``scene_objects``, ``removed_objects``)."""
        return SceneEdit(tuple(cls.scene_objects), tuple(cls.removed_objects))

    @property
    def robot_view(self) -> RobotView:
        """Move groups of the task's robot (``robot.robot_view.RobotView``)."""
        return self.scene.robots[self.robot_name].view

    # -- to override ----------------------------------------------------------------------
    def robot_config(self) -> RobotConfig:
        """Robot config of the joint flavour (move groups, initial qpos, command modes);
        subclasses return theirs."""
        raise NotImplementedError

    def ee_robot_config(self) -> RobotConfig:
        """Robot config of the end-effector (mocap) flavour; only bimanual tasks have one."""
        raise UserError(f"task sampler {type(self).__name__} has no end-effector flavour")

    def objects(self) -> dict[str, tuple[str, str | None]]:
        """Free-joint objects of the scene: name -> (joint, geom)."""
        return {}

    def randomize_scene(self, scene: Scene, robot_view: RobotView) -> dict[str, Any] | None:
        """Domain randomization of the freshly reset scene from ``self.rng``: lighting,
        table texture and colours, object colours, friction, object masses, joint damping,
        camera poses and initial arm joint noise, each as the config's ``randomization``
        section says. Returns the record of what was applied (``tasks.randomization``), or
        None when the sampler does not randomize (the scene is then nominal).

        Subclasses may extend it (call ``super()`` first); the task's own episode
        distribution (object poses, goals) belongs in ``_sample_task``.
        """
        if not self.randomize:
            self.randomizer.restore()
            return None
        return self.randomizer.randomize(self.rng, scene.data)

    def _sample_task(self, scene: Scene) -> Task | None:
        """Place the task's objects from ``self.rng`` and build its task (not reset), or
        None when this draw gives no valid episode (``sample_task`` then returns None)."""
        raise NotImplementedError

    # -- API ------------------------------------------------------------------------------
    def sample_task(
        self,
        seed: Seed = None,
        object_poses: Mapping[str, Any] | None = None,
        randomization: Mapping[str, Any] | None = None,
    ) -> Task | None:
        """A ready task (scene reset, randomized, task built and reset), or None when
        this draw gives no valid episode (call again: the generator has moved on).

        Args:
            seed: int or ``np.random.Generator`` that becomes ``self.rng`` (the only source
                of randomness); None: continue with ``self.rng``.
            object_poses: object name -> pose [xyz, quat wxyz] placed after sampling
                (e.g. to replay an episode from its recorded start).
            randomization: a record (``tasks.randomization``) applied instead of sampling
                one, e.g. the randomization of the episode being replayed.
        """
        if seed is not None:
            self.rng = as_generator(seed)
        # positions only, and no forward at the end of start_episode: task.reset() holds
        # the controls and forwards
        self.scene.reset(settle=False)
        task = self.start_episode(self.rng, object_poses, randomization, forward=False)
        if task is not None:
            task.reset()
        return task

    def next_task(
        self,
        seed: Seed = None,
        object_poses: Mapping[str, Any] | None = None,
        randomization: Mapping[str, Any] | None = None,
        max_tries: int = MAX_SAMPLE_TRIES,
    ) -> Task:
        """``sample_task`` until it gives a task.

        Args:
            seed: as for :meth:`sample_task`.
            object_poses: as for :meth:`sample_task`.
            randomization: as for :meth:`sample_task`.
            max_tries: the most draws.

        Raises:
            UserError: no valid episode in ``max_tries`` draws.
        """
        for attempt in range(max_tries):
            task = self.sample_task(seed if attempt == 0 else None, object_poses, randomization)
            if task is not None:
                return task
        raise UserError(
            f"task sampler {type(self).__name__} found no valid episode in {max_tries} draws; "
            "check the spawn and goal regions of the task config"
        )

    def start_episode(
        self,
        rng: np.random.Generator,
        object_poses: Mapping[str, Any] | None = None,
        randomization: Mapping[str, Any] | None = None,
        forward: bool = True,
    ) -> Task | None:
        """Randomize the current scene, sample the task and place the objects; the task is
        built but not reset (the dm_control front doors reset through their own hooks).

        Args:
            rng: the generator of this episode's draws.
            object_poses: object name -> pose [xyz m, quat wxyz] placed after sampling.
            randomization: a record applied instead of sampling one.
            forward: update the positions of everything (``mj_forward``) at the end.

        Returns:
            The task, or None when the draw gives no valid episode.
        """
        self.rng = rng
        if randomization is not None:
            self.randomizer.apply(randomization, self.scene.data)
            self.randomization = dict(randomization)
        else:
            self.randomization = self.randomize_scene(self.scene, self.robot_view)
        if self.randomization is not None:
            self.scene.forward()  # positions of the randomized scene, for _sample_task
        task = self._sample_task(self.scene)
        if task is None:
            return None
        for name, pose in (object_poses or {}).items():
            if name not in self.scene.objects:
                raise unknown_name_error("object", name, self.scene.objects)
            self.scene.objects[name].set_pose(self.scene.data, np.asarray(pose, dtype=float))
        if forward:
            self.scene.forward()
        return task

    def make_task(self, **params: Any) -> Task:
        """A task over the current scene with explicit episode parameters (no reset)."""
        return self.task_cls(self.scene, self.config, **params)

    def close(self) -> None:
        """Close the scene this sampler owns (renderers included)."""
        self.scene.close()

    def __enter__(self) -> TaskSampler:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
