"""Data collection: scripted rollout -> joint replay with cameras -> episode files."""

__all__: list[str] = []  # submodules only: import them by name
