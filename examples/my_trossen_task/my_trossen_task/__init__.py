"""An example task package for trossen_arm_mujoco: the kit's right arm lifts a puck.

``my_trossen_task.task.TASK`` is the task's declaration; the package's entry point (group
``trossen_arm_mujoco.tasks``, in ``pyproject.toml``) makes it known as ``lift_puck``.
"""
