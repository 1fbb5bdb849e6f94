"""Resume planning helpers that need no recording (``plan_run`` is exercised by the recorder's
tests in ``test_parallel.py``)."""

from __future__ import annotations

from trossen_arm_mujoco.collect.resume import format_indices


def test_format_indices_shows_gaps():
    assert format_indices([0, 5]) == "episodes 0, 5"
    assert format_indices([7, 0, 1, 2, 5, 8]) == "episodes 0..2, 5, 7..8"
    assert format_indices([3]) == "episode 3"
    assert format_indices([]) == "none"
