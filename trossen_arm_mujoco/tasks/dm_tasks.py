"""dm_control adapters of the registered bimanual tasks (``TransferCubeEETask``, ...).

An adapter is a thin ``TrossenAIStationaryEETask`` / ``TrossenAIStationaryTask`` whose world
is built by the task's registered sampler over the dm_control ``Physics``, and whose hooks
delegate to the registered task: ``initialize_episode`` places the objects with the
sampler (from this task's generator, or from the poses given at construction),
``get_env_state`` and ``get_reward`` ask the task. Subclasses may still override any hook.

Domain randomization: ``randomize=True`` randomizes every episode from this task's generator
(as the task config's ``randomization`` section says); ``randomization=record`` applies one
record at every reset instead, e.g. the EE env's ``applied_randomization`` handed to the joint
env that replays its trajectory (the two then see the same scene).

Docs: docs/reference/dm-control-envs.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.scene import Scene
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler import MAX_SAMPLE_TRIES
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.stationary import (
    StationaryTaskBase,
    TrossenAIStationaryEETask,
    TrossenAIStationaryTask,
)

__all__ = [
    "BOX_POSE",
    "RegisteredTaskMixin",
    "TransferCubeEETask",
    "TransferCubeTask",
    "dm_task_class",
]

#: Cube pose used by ``TransferCubeTask`` at the next reset when no ``box_pose`` is given
#: (vendor-compatible hand-over: ``sim_env.BOX_POSE[0] = pose`` before ``env.reset()``).
BOX_POSE: list[np.ndarray | None] = [None]


class RegisteredTaskMixin(StationaryTaskBase):
    """Serves registered task ``task_name`` through the dm_control hooks.

    Args:
        *args: the base's.
        object_poses: object name -> initial pose [xyz, quat wxyz] used at every reset
            instead of sampled ones (e.g. to replay a recorded episode).
        randomize: domain randomization of every episode (default off).
        randomization: a randomization record (``tasks.randomization``) applied at every
            reset instead of sampling one.
        **kwargs: the base's.
    """

    task_name: ClassVar[str] = ""

    def __init__(
        self,
        *args: Any,
        object_poses: Mapping[str, Any] | None = None,
        randomize: bool = False,
        randomization: Mapping[str, Any] | None = None,
        **kwargs: Any,
    ):
        super().__init__(*args, **kwargs)
        self.randomize = bool(randomize)
        self.randomization = None if randomization is None else dict(randomization)
        self.object_poses = (
            None
            if object_poses is None
            else {k: np.asarray(v, dtype=float) for k, v in object_poses.items()}
        )
        self.entry = registry.load(self.task_name)
        self.max_reward = self.entry.task_class().max_reward
        self.sampler = None
        self.task = None

    def build_scene(self, physics) -> Scene:
        settings = SamplerSettings(
            flavour=self.FLAVOUR,
            camera_names=tuple(self.cam_list),
            height=self.image_size[0],
            width=self.image_size[1],
            randomize=self.randomize,
        )
        self.sampler = registry.make_sampler(self.task_name, settings, physics=physics)
        return self.sampler.scene

    def episode_object_poses(self) -> Mapping[str, Any] | None:
        """Poses placed at the next reset (None: sampled from this task's generator)."""
        return self.object_poses

    def initialize_episode(self, physics) -> None:
        self.initialize_robots(physics)
        self.scene(physics)
        poses = self.episode_object_poses()
        for _ in range(MAX_SAMPLE_TRIES):
            self.task = self.sampler.start_episode(self.rng, poses, self.randomization)
            if self.task is not None:
                break
        else:
            raise UserError(
                f"task '{self.task_name}': no valid episode in {MAX_SAMPLE_TRIES} draws"
            )
        super().initialize_episode(physics)

    @property
    def applied_randomization(self) -> dict[str, Any] | None:
        """Randomization record of the current episode (None: nominal scene)."""
        return None if self.sampler is None else self.sampler.randomization

    def get_env_state(self, physics) -> np.ndarray:
        """Poses of the task's objects, [xyz, quat wxyz] each (7 per object)."""
        return self.task.env_state()

    def get_reward(self, physics):
        return self.task.get_reward()


class TransferCubeEETask(RegisteredTaskMixin, TrossenAIStationaryEETask):
    """Pick the cube with the right arm and hand it to the left arm; reward 0-4 (mocap)."""

    task_name = "sim_transfer_cube"


class TransferCubeTask(RegisteredTaskMixin, TrossenAIStationaryTask):
    """The cube transfer in the joint env; the cube starts at ``box_pose`` (or
    ``BOX_POSE[0]``, or a pose sampled from this task's generator).

    Args:
        *args: as for :class:`RegisteredTaskMixin`.
        box_pose: the cube's pose at every reset, (7,) [xyz m, quat wxyz]; None: as above.
        **kwargs: as for :class:`RegisteredTaskMixin`.
    """

    task_name = "sim_transfer_cube"

    def __init__(self, *args: Any, box_pose: np.ndarray | None = None, **kwargs: Any):
        if box_pose is not None:
            kwargs["object_poses"] = {"box": box_pose}
        super().__init__(*args, **kwargs)

    @property
    def box_pose(self) -> np.ndarray | None:
        """The cube's pose placed at every reset, (7,) [xyz m, quat wxyz]; None: sampled."""
        return None if self.object_poses is None else self.object_poses["box"]

    def episode_object_poses(self):
        if self.object_poses is None and BOX_POSE[0] is not None:
            return {"box": BOX_POSE[0]}
        return self.object_poses


_ADAPTERS: dict[tuple[str, str], type] = {
    ("sim_transfer_cube", "ee"): TransferCubeEETask,
    ("sim_transfer_cube", "joint"): TransferCubeTask,
}


def dm_task_class(name: str, flavour: str) -> type:
    """The dm_control task class of registered task ``name`` in ``flavour`` ("ee" or
    "joint"): a documented class when there is one, else an adapter made (once) here."""
    name = registry.canonical(name)
    key = (name, flavour)
    if key not in _ADAPTERS:
        config = registry.load(name).load_config()
        scene_key = {"ee": "ee_scene", "joint": "scene"}[flavour]
        base = TrossenAIStationaryEETask if flavour == "ee" else TrossenAIStationaryTask
        _ADAPTERS[key] = type(
            f"{name}_{flavour}_task",
            (RegisteredTaskMixin, base),
            {"task_name": name, "DEFAULT_XML": config[scene_key]},
        )
    return _ADAPTERS[key]
