"""Malformed actions and reset options: an ``InvalidInput`` (a UserError and a ValueError)
naming the action space or the accepted reset options; gymnasium's wrappers, vector envs
and stable-baselines3's env checker still work."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.inputs import InvalidInput

REACH = "TrossenMujoco/WXAIReach-v0"
SPACE = r"\(action space Box\(-1.0, 1.0, \(4,\), float32\)\)"


@pytest.mark.parametrize(
    "action, match",
    [
        ("forward", SPACE + ", got str 'forward'"),
        (None, SPACE + ", got NoneType"),
        ({"arm": 1}, SPACE + ", got dict"),
        ([[0.0, 0.1], [0.2]], SPACE + ", got list"),
        (np.array(["a", "b", "c", "d"]), SPACE + ", got an array of dtype <U1"),
        (np.zeros(4, dtype=bool), SPACE + ", got an array of dtype bool"),
        (np.zeros(3, dtype=np.float32), r"shape \(4,\) " + SPACE + r", got shape \(3,\)"),
        (np.zeros((2, 4)), r"got shape \(2, 4\)"),
        (np.array([0.0, np.nan, 0.0, 0.0]), r"NaN or inf: .*finite values in \[-1, 1\]"),
        ([0.0, 0.0, np.inf, 0.0], "NaN or inf"),
    ],
)
def test_a_malformed_action_names_the_action_space(make_env, action, match):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    with pytest.raises(InvalidInput, match=match) as err:
        env.step(action)
    assert isinstance(err.value, UserError) and isinstance(err.value, ValueError)
    assert "\n" not in str(err.value)
    env.step(env.action_space.sample())  # the env goes on


@pytest.mark.parametrize(
    "action",
    [
        [0.0, 0.1, -0.2, 1.0],
        (0, 0, 0, 1),
        np.zeros(4, dtype=np.int64),
        np.zeros((1, 4)),
        np.ones(4, dtype=np.float64) * 3,
    ],
)
def test_number_sequences_of_the_right_size_are_actions(make_env, action):
    env = make_env(REACH, action_mode="ee_delta")
    env.reset(seed=0)
    env.step(action)


@pytest.mark.parametrize(
    "options, match",
    [
        ({"seed": 3}, "unknown reset option 'seed'; accepted keys: object_poses"),
        ({"object_pose": {}}, "unknown reset option 'object_pose'; accepted keys: object_poses"),
        ([("object_poses", None)], "reset options must be a dict .*got list"),
        ({"object_poses": [0.3, 0.0, 0.02, 1, 0, 0, 0]}, "object_poses must be a dict"),
        (
            {"object_poses": {"mug": [0.3, 0, 0.02, 1, 0, 0, 0]}},
            "unknown object of reset option object_poses 'mug'; valid .*: box",
        ),
        ({"object_poses": {"box": [0.3, 0.0, 0.02]}}, r"object_poses\['box'\] must be 7 finite"),
        ({"object_poses": {"box": "here"}}, r"object_poses\['box'\] must be 7 finite"),
        ({"object_poses": {"box": [0.3, 0, 0.02, 0, 0, 0, 0]}}, "non-zero quaternion"),
    ],
)
def test_bad_reset_options_list_the_accepted_keys(make_env, options, match):
    env = make_env("TrossenMujoco/StationaryAITransferCube-v0")
    with pytest.raises(InvalidInput, match=match) as err:
        env.reset(seed=0, options=options)
    assert isinstance(err.value, ValueError) and "\n" not in str(err.value)


def test_reset_options_place_objects_and_empty_ones_change_nothing(make_env):
    env = make_env("TrossenMujoco/StationaryAITransferCube-v0")
    plain = env.reset(seed=4)[0]
    assert np.array_equal(env.reset(seed=4, options={})[0], plain)
    assert np.array_equal(env.reset(seed=4, options={"object_poses": None})[0], plain)
    pose = [0.05, 0.1, 0.045, 1.0, 0.0, 0.0, 0.0]
    env.reset(seed=4, options={"object_poses": {"box": pose}})
    placed = env.unwrapped.scene.objects["box"].get_pose(env.unwrapped.scene.data)
    assert np.allclose(placed, pose)


def test_wrappers_and_vector_envs_with_autoreset_still_work():
    """gymnasium's vector envs reset with ``options=None`` (or ``{}``) and autoreset."""
    for cls in (gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv):
        envs = cls([lambda: gym.make(REACH, max_episode_steps=3)] * 2)  # Linux: fork
        try:
            envs.reset(seed=1)
            envs.reset(seed=1, options={})
            for _ in range(7):  # past two time limits: autoreset
                envs.step(envs.action_space.sample())
        finally:
            envs.close()
    env = gym.wrappers.RecordEpisodeStatistics(gym.wrappers.ClipAction(gym.make(REACH)))
    env.reset(seed=0, options=None)
    env.step(env.action_space.sample())
    env.close()


def test_stable_baselines3_env_checker_passes():
    env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(REACH)
    try:
        env_checker.check_env(env.unwrapped, warn=False)
    finally:
        env.close()
