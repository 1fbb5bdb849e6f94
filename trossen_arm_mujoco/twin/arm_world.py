"""The served single arm's world: one WidowX AI arm and a single-arm task's objects (``push``,
``pick_place``, ``reach``), stepping in real time in a thread.

:class:`ArmWorld` is :class:`~.kit_world.KitWorld` with one arm, named ``follower`` (its
``arms``, ``qadr``, ``act`` ... are keyed by it; ``twin.arm_adapter.ArmAdapter(world,
"follower")`` serves it): the task's joint flavour built through ``tasks.registry``, the arm's
7 driver values (``joint_0`` .. ``joint_5`` rad, the gripper's ``left_carriage_joint`` travel
m) commanded every control tick (the physics step, 2 ms), the coupled finger following through
the model's equality constraint. Episode ``k`` of a world made with ``base_seed=S`` is the
scene ``record --seed S`` records as its episode ``k`` (the cube and the goal), and frames
hold the arm's 7 values (``qpos``, ``qvel``, ``action``: the recordings' ``widowxai``
layout).

Docs: docs/cli/serve.md (The single arm).
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import ARM_JOINTS
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.twin.kit_world import KitWorld

__all__ = ["ARM_SIDE", "ArmWorld", "is_arm_world_task"]

#: The name of the served single arm (its adapter's and server's ``side``).
ARM_SIDE = "follower"


def is_arm_world_task(task: str) -> bool:
    """Whether ``task`` (a name or alias) is a single arm's task (an ``ArmWorld`` holds it:
    ``tasks.registry.arm_names``)."""
    return registry.ALIASES.get(task, task) in registry.arm_names()


class ArmWorld(KitWorld):
    """One arm and a single-arm task's objects; see the module doc. Arguments as
    ``KitWorld`` (``task_name`` a single arm's task, default ``registry.DEFAULT_ARM_TASK``)."""

    sides: tuple[str, ...] = (ARM_SIDE,)
    groups: tuple[str, ...] = ("arm", "gripper")

    def __init__(self, task_name: str = registry.DEFAULT_ARM_TASK, **kwargs) -> None:
        super().__init__(task_name, **kwargs)

    def check_task(self, entry: registry.TaskEntry) -> None:
        """A one-line ``UserError`` unless ``entry`` is a single arm's task."""
        if not is_arm_world_task(entry.name):
            raise UserError(
                f"task '{entry.name}' is not a single-arm task; a served arm holds one of: "
                f"{', '.join(registry.arm_names())}"
            )

    def mjcf_name(self, side: str, name: str) -> str:
        """The single arm's model names carry no prefix."""
        return name

    def layout_joints(self) -> list[str]:
        """The recorded 7 values' joints: ``joint_0`` .. ``joint_5``, ``left_carriage_joint``."""
        return [*ARM_JOINTS, "left_carriage_joint"]

    def object_poses(self) -> dict[str, np.ndarray]:
        """Object name -> pose (7,) [xyz m, quat wxyz] now, in the scene's order."""
        data = self.data
        return {name: obj.get_pose(data) for name, obj in self.scene.objects.items()}

    def action(self) -> np.ndarray:
        """The commanded targets, the arm's 7 values (rad; gripper m)."""
        return self.arms[ARM_SIDE].target.copy()

    def joint_commands(self, vector: np.ndarray) -> dict[str, np.ndarray]:
        """The robot's commands of the arm's 7 targets: ``arm`` 6, ``gripper`` 1."""
        v = np.asarray(vector, dtype=float)
        return {"arm": v[:6], "gripper": v[6:7]}

    def goal(self) -> np.ndarray | None:
        """The running episode's goal (3,) m, world (None: the task has none)."""
        goal = getattr(self.task, "goal", None)
        return None if goal is None else np.array(goal, dtype=float)
