"""Helpers of the documented public surface: sample_box_pose, make_sim_env, Quaternion.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from dm_control.rl import control

from trossen_arm_mujoco.assets import asset_path
from trossen_arm_mujoco.constants import DT, SIM_TASK_CONFIGS
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.sim.scene import load_physics
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.dm_tasks import RegisteredTaskMixin
from trossen_arm_mujoco.tasks.transfer_cube import sample_cube_pose

__all__ = ["Quaternion", "make_sim_env", "sample_box_pose"]


def sample_box_pose(rng: np.random.Generator | int | None = None) -> np.ndarray:
    """Random cube pose resting on the table: [x, y, z, qw, qx, qy, qz] (world frame, m).

    x ~ U[-0.15, 0.15], y ~ U[-0.2, 0.1], z = 0.0325 (cube resting on the table top).
    Pass a ``np.random.Generator`` or an int seed for reproducible poses; with nothing,
    a fresh unseeded generator is used.
    """
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    return sample_cube_pose(rng)


def make_sim_env(
    task_class: type,
    xml_file: str | None = None,
    task_name: str = registry.DEFAULT_TASK,
    onscreen_render: bool = False,
    cam_list: Sequence[str] | None = None,
    *,
    image_size: tuple[int, int] = (480, 640),
    random: int | np.random.Generator | None = None,
    time_limit: float = 20.0,
    randomize: bool = False,
    shadows: bool = True,
    visual: str = "own",
    **task_kwargs,
) -> control.Environment:
    """A dm_control environment for a Stationary AI task class.

    Args:
        task_class: e.g. ``TransferCubeEETask`` (mocap) or ``TransferCubeTask`` (joint), or a
            user subclass of ``TrossenAIStationaryEETask`` / ``TrossenAIStationaryTask``.
        xml_file: scene path, relative to ``ASSETS_DIR`` unless absolute; default: the task
            class's scene (``stationary_ai/trossen_ai_scene.xml`` or ``..._scene_joint.xml``).
        task_name: a key of ``SIM_TASK_CONFIGS`` (checked; the task class decides the task).
        onscreen_render: kept for compatibility; live display is done by the scripts.
        cam_list: cameras rendered into ``observation["images"]``; None = all 4, [] = none.
        image_size: (height, width) of the images.
        random: seed or Generator for the task's randomization.
        time_limit: episode time limit (s).
        randomize: domain randomization of every episode (registered tasks only; see the
            task config's ``randomization`` section); ``env.task.applied_randomization`` is
            the record of the current episode, ``randomization=record`` (a task keyword)
            applies a given one at every reset instead.
        shadows: whether the key light casts shadows in the images (False: faster).
        visual: ``"own"`` arm meshes, or ``"menagerie"``: the official Trossen meshes of the
            MuJoCo Menagerie checkout named by ``TROSSEN_MENAGERIE_DIR`` (drawing only).
    Returns:
        ``control.Environment`` whose ``reset()``/``step(action)`` return time steps with
        ``.observation`` and ``.reward``; control period ``DT`` = 0.02 s.
    """
    if registry.ALIASES.get(task_name, task_name) not in SIM_TASK_CONFIGS:
        raise unknown_name_error("task", task_name, SIM_TASK_CONFIGS)
    if not isinstance(task_class, type):
        raise UserError(f"task_class must be a class, got {type(task_class).__name__}")
    if randomize:
        if not issubclass(task_class, RegisteredTaskMixin):
            raise UserError(
                f"randomize=True needs a registered task class (e.g. TransferCubeEETask); "
                f"{task_class.__name__} does not randomize"
            )
        task_kwargs["randomize"] = True
    xml = str(asset_path(xml_file or task_class.DEFAULT_XML))
    edit = None  # a registered task's own scene objects (TaskSampler.scene_objects)
    if issubclass(task_class, RegisteredTaskMixin) and task_class.task_name:
        edit = registry.load(task_class.task_name).sampler_class().scene_edit()
    physics = load_physics(xml, SceneLooks(shadows=shadows, visual=visual), edit)
    task = task_class(
        random=random,
        onscreen_render=onscreen_render,
        cam_list=cam_list,
        image_size=image_size,
        **task_kwargs,
    )
    if hasattr(task, "scene"):
        task.scene(physics)  # look names (cameras, joints, sites) up now, not at reset
    return control.Environment(
        physics,
        task,
        time_limit=time_limit,
        control_timestep=DT,
        n_sub_steps=None,
        flat_observation=False,
    )
