"""Shared pieces of the gym tests: headless rendering, env factory that always closes."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported

import gymnasium as gym  # noqa: E402
import pytest  # noqa: E402

import trossen_arm_mujoco  # noqa: E402,F401  (registers the ids)


@pytest.fixture
def make_env():
    """``make_env(id, **kwargs)`` -> gymnasium env, closed after the test."""
    made = []

    def _make(env_id: str, **kwargs):
        env = gym.make(env_id, **kwargs)
        made.append(env)
        return env

    yield _make
    for env in made:
        env.close()
