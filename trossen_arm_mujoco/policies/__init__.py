"""Scripted policies: the waypoint machinery (``policies.scripted``) and one module per task
that has scripted demonstrations.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

__all__: list[str] = []
