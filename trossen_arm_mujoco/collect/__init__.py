"""Data collection: scripted rollout -> joint replay with cameras -> episode files.

Docs: docs/cli/record.md.
"""

__all__: list[str] = []  # submodules only: import them by name
