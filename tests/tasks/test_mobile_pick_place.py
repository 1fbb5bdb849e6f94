"""mobile_pick_place: the sampler randomizes the base's start pose and the cube, the reward
passes its stages in order under the scripted policy, which drives to the table, picks and
places the cube (success), the base's commands within the real base's limits."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.policies.mobile_pick_place import MobilePickPlacePolicy, planar_pose
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.mobile_pick_place import STAGES

NAME = "mobile_pick_place"


@pytest.fixture(scope="module")
def sampler():
    s = registry.make_sampler(NAME)
    yield s
    s.close()


def test_entry_facts():
    entry = registry.load(NAME)
    assert registry.stages(NAME) == STAGES
    assert list(STAGES.values()) == [1.0, 2.0, 3.0, 4.0]
    assert entry.record["cam_names"] == ["cam_high", "cam_left_wrist", "cam_right_wrist"]
    assert NAME in registry.scripted_names() and NAME not in registry.kit_names()


def test_sampler_randomizes_base_and_cube(sampler):
    config = sampler.config
    seen = []
    for seed in range(4):
        obs = sampler.sample_task(seed).get_observation()
        pose, cube = np.array(planar_pose(obs["base_pose"])), obs["env_state"][:3]
        assert np.all(pose >= np.array(config["base_start_low"]) - 1e-9)
        assert np.all(pose <= np.array(config["base_start_high"]) + 1e-9)
        assert np.all(cube[:2] >= config["cube_low"]) and np.all(cube[:2] <= config["cube_high"])
        assert cube[2] == pytest.approx(config["table_height"] + 0.025)
        seen.append(np.concatenate([pose, cube]))
    assert len({tuple(np.round(s, 6)) for s in seen}) == 4
    np.testing.assert_array_equal(
        sampler.sample_task(2).get_observation()["env_state"], seen[2][3:].tolist() + [1, 0, 0, 0]
    )


def test_reward_starts_at_zero_and_refuses_a_wrong_action_size(sampler):
    task = sampler.sample_task(0)
    assert task.get_reward() == 0 and not task.judge_success()
    with pytest.raises(ValueError, match="16 values"):
        MOBILEAI_LAYOUT.commands(np.zeros(14))


def test_scripted_policy_drives_picks_and_places(sampler):
    task = sampler.sample_task(3)
    policy = MobilePickPlacePolicy(task)
    obs = task.get_observation()
    rewards, base_cmds = [], []
    for _ in range(registry.load(NAME).record["episode_len"]):
        action = policy(obs)
        base_cmds.append(action[14:])
        obs, reward, _ = task.step(MOBILEAI_LAYOUT.commands(action))
        rewards.append(reward)
    rewards = np.array(rewards)
    firsts = [int(np.argmax(rewards >= level)) for level in STAGES.values()]
    assert all(rewards.max() >= level for level in STAGES.values()), rewards.max()
    assert firsts == sorted(firsts)  # at the table, touched, lifted, placed: in this order
    assert task.judge_success() and rewards[-1] == 4
    cube, target = obs["env_state"][:3], obs["target"]
    assert np.hypot(*(cube[:2] - target[:2])) < 0.03
    assert np.abs(np.array(base_cmds)).max() <= 0.5  # within the base's +-1.0 limits
    assert task.robot.controllers["base"].clipped_commands == 0
