"""Data collection: scripted rollout -> joint replay with cameras -> episode files."""
