"""Samplers: seeds decide episodes, bit for bit; spawn and goal regions."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler import as_generator


@pytest.fixture(scope="module")
def samplers():
    made = {name: registry.make_sampler(name) for name in registry.names()}
    yield made
    for sampler in made.values():
        sampler.close()


def _state(sampler, task):
    data = sampler.env.data
    goal = task.desired_goal() if task.goal_conditioned else np.zeros(0)
    return np.concatenate([data.qpos, data.qvel, data.ctrl, data.mocap_pos.ravel(), goal])


@pytest.mark.parametrize("name", registry.names())
def test_same_seed_same_episode(samplers, name):
    sampler = samplers[name]
    a = _state(sampler, sampler.sample_task(7))
    sampler.sample_task(8)
    b = _state(sampler, sampler.sample_task(7))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", registry.names())
def test_different_seeds_differ(samplers, name):
    sampler = samplers[name]
    a = _state(sampler, sampler.sample_task(1))
    b = _state(sampler, sampler.sample_task(2))
    assert not np.array_equal(a, b)


def test_generator_and_int_seed_agree(samplers):
    sampler = samplers["push"]
    a = _state(sampler, sampler.sample_task(3))
    b = _state(sampler, sampler.sample_task(np.random.default_rng(3)))
    np.testing.assert_array_equal(a, b)


def test_bad_seed_type():
    with pytest.raises(UserError, match="seed"):
        as_generator("3")


def test_regions(samplers):
    reach, push, pick = samplers["reach"], samplers["push"], samplers["pick_place"]
    lo, hi = np.array(reach.config["target_low"]), np.array(reach.config["target_high"])
    n_air = 0
    for seed in range(20):
        target = reach.sample_task(seed).desired_goal()
        assert np.all(target >= lo) and np.all(target <= hi)
        task = push.sample_task(seed)
        cube, goal = task.cube_pos(), task.desired_goal()
        assert np.all(cube[:2] >= push.config["cube_low"]) and np.all(
            cube[:2] <= push.config["cube_high"]
        )
        assert goal[2] == pytest.approx(0.02) and cube[2] == pytest.approx(0.02)
        assert np.linalg.norm(goal[:2] - cube[:2]) >= push.config["min_goal_distance"]
        goal = pick.sample_task(seed).desired_goal()
        assert 0.02 - 1e-9 <= goal[2] <= pick.config["goal_high"][2]
        n_air += goal[2] > 0.021
    assert 0 < n_air < 20


def test_marker_shows_goal(samplers):
    sampler = samplers["push"]
    task = sampler.sample_task(4)
    np.testing.assert_allclose(sampler.env.data.mocap_pos[0], task.desired_goal())
