"""What an episode is: tasks (reward, success, timing) and samplers (randomization).

``tasks.registry`` maps task names ("reach", "push", "pick_place", "transfer_cube") to their
task class, sampler class and YAML config; ``tasks.task.Task`` and ``tasks.sampler.TaskSampler``
are the bases. Nothing is imported here, so importing the package stays cheap.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

__all__: list[str] = []  # submodules only: import them by name
