"""The example task, through trossen_arm_mujoco's own front doors: the registry finds it
through the package's entry point, its sampler places the puck it adds to the kit's scene,
the scripted policy lifts it (reward 2, both stages), and its gym id steps."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import trossen_arm_mujoco  # noqa: F401  (registers the gym ids, this package's included)
from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.tasks import registry


def test_the_registry_finds_the_task_through_the_entry_point():
    entry = registry.load("lift_puck")
    assert entry.package == "my-trossen-task"
    assert "lift_puck" in registry.kit_names() and "lift_puck" in registry.scripted_names()
    assert registry.stages("lift_puck") == {"touched": 1.0, "lifted": 2.0}
    assert "lift_puck" not in registry.problems()


def test_the_sampler_places_the_puck_in_its_range_from_the_seed_only():
    with registry.make_sampler("lift_puck") as sampler:
        poses = [sampler.sample_task(seed).object_poses()["puck"] for seed in (0, 0, 1)]
        assert "box" not in sampler.scene.objects  # the shipped cube was removed
        assert sampler.sample_task(2).get_reward() == 0  # nothing touches it at the start
    np.testing.assert_array_equal(poses[0], poses[1])
    assert not np.array_equal(poses[0], poses[2])
    for pose in poses:
        assert -0.08 <= pose[0] <= 0.08 and -0.15 <= pose[1] <= 0.0


def test_a_config_key_of_its_own_is_checked():
    from trossen_arm_mujoco.errors import UserError

    with pytest.raises(UserError, match="puck_low"):
        registry.make_sampler("lift_puck", puck_low=[0.1])


def test_the_scripted_policy_lifts_the_puck(tmp_path):
    recorder = EpisodeRecorder(RecordSettings(task_name="lift_puck", episode_len=240))
    try:
        outcome = recorder.record(0, tmp_path / "episode_0.hdf5")
    finally:
        recorder.close()
    assert outcome.max_reward == 2 and outcome.final_reward == 2
    episode = load_episode(outcome.path)
    assert list(episode.attrs["object_names"]) == ["puck"]
    assert episode.env_state[-1, 2] > 0.1  # lifted 13 cm off the table (top at 0.02 m)


def test_the_gym_id_steps():
    env = gym.make("MyTrossen/LiftPuck-v0")
    try:
        obs, _ = env.reset(seed=0)
        obs, reward, *_ = env.step(env.action_space.sample())
        assert reward == 0 and np.all(np.isfinite(obs))
    finally:
        env.close()
