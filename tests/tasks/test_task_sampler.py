"""Samplers: seeds decide episodes, bit for bit; spawn and goal regions."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler import as_generator
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings


@pytest.fixture(scope="module")
def samplers():
    made = {name: registry.make_sampler(name) for name in registry.names()}
    yield made
    for sampler in made.values():
        sampler.close()


def _state(sampler, task):
    data = sampler.scene.data
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
    np.testing.assert_allclose(sampler.scene.data.mocap_pos[0], task.desired_goal())


# --- the sampler interface ------------------------------------------------------------------
def test_sampler_seed_is_its_generator():
    with registry.make_sampler("reach", seed=5) as a, registry.make_sampler("reach") as b:
        first = _state(a, a.sample_task())  # continues the sampler's own generator
        np.testing.assert_array_equal(first, _state(b, b.sample_task(5)))
        assert not np.array_equal(_state(a, a.sample_task()), first)


def test_sample_task_is_none_when_no_valid_episode():
    """Push needs a goal min_goal_distance from the cube: an impossible one gives None."""
    with registry.make_sampler("push", min_goal_distance=10.0) as sampler:
        assert sampler.sample_task(0) is None
        with pytest.raises(UserError, match="no valid episode in 3 draws"):
            sampler.next_task(0, max_tries=3)


def test_next_task_retries_until_a_task_comes(samplers):
    sampler = samplers["reach"]
    real = type(sampler)._sample_task
    calls = []

    def flaky(self, scene):
        calls.append(1)
        return None if len(calls) < 3 else real(self, scene)

    type(sampler)._sample_task = flaky
    try:
        task = sampler.next_task(0)
    finally:
        type(sampler)._sample_task = real
    assert task is not None and task.n_steps == 0 and len(calls) == 3


def test_randomize_scene_takes_env_and_robot_view(samplers):
    sampler = samplers["reach"]
    sampler.scene.reset()
    assert sampler.randomize_scene(sampler.scene, sampler.robot_view) is None  # off by default
    assert {"arm", "gripper"} <= set(sampler.robot_view.move_groups)


def test_sampler_owns_and_closes_its_env():
    with registry.make_sampler(
        "reach", SamplerSettings(camera_names=["overview"], height=8, width=8)
    ) as s:
        s.sample_task(0)
        s.scene.render_images()
        assert s.scene.cameras._renderer is not None
    assert s.scene.cameras._renderer is None


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_randomize_must_be_a_bool(value):
    with pytest.raises(UserError, match="randomize must be True or False"):
        registry.make_sampler("reach", SamplerSettings(randomize=value))


@pytest.mark.parametrize(
    "low, high, size",
    [
        ([0.18, -0.22, 0.06], [0.42, 0.22, 0.32], None),
        (-0.05, 0.05, 6),
        (-np.pi, np.pi, None),
        (0.0, [1.0, 2.0], None),
        (0.0, 1.0, (2, 3)),
    ],
)
def test_uniform_draws_what_the_arithmetic_written_out_drew(low, high, size):
    """The samplers' uniform() (Generator.uniform) gives, bit for bit, the values and the
    stream of ``low + (high - low) * rng.random(shape)``, which the samplers computed before:
    episodes recorded then are drawn again the same."""
    from trossen_arm_mujoco.tasks.sampler import uniform

    for seed in range(50):
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        lo = np.asarray(low, dtype=float)
        span = np.asarray(high, dtype=float) - lo
        want = lo + span * a.random(span.shape if size is None else size)
        got = uniform(b, low, high, size)
        assert np.shape(got) == np.shape(want) and np.array_equal(got, want)
        assert a.random() == b.random()  # the generators moved on alike
