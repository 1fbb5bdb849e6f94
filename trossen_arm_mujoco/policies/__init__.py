"""Scripted policies: the waypoint machinery (``policies.scripted``) and one module per task
that has scripted demonstrations."""

__all__: list[str] = []
