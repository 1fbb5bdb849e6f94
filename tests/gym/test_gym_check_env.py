"""gymnasium's and stable-baselines3's env checkers on every registered id."""

from __future__ import annotations

import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

from trossen_arm_mujoco.gym.registration import ENV_IDS

sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")

IDS = sorted(ENV_IDS)
#: tiny images keep the pixel checks fast (36x36 is SB3's smallest CNN input)
TINY = {"width": 36, "height": 36}

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("action_mode", ["joint_position", "ee_delta"])
def test_gymnasium_check_env_state(make_env, env_id, action_mode):
    gym_check_env(make_env(env_id, action_mode=action_mode).unwrapped)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env_state(make_env, env_id):
    sb3_checker.check_env(make_env(env_id, action_mode="joint_rel_position").unwrapped)


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_pixels_state(make_env, env_id):
    env = make_env(env_id, obs_type="pixels_state", render_mode="rgb_array", **TINY)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_checker.check_env(env.unwrapped)


@pytest.mark.parametrize("env_id", ["TrossenMujoco/WXAIPush-v0", "TrossenMujoco/WXAIReachGoal-v0"])
def test_check_env_pixels_with_render_modes(make_env, env_id):
    env = make_env(env_id, obs_type="pixels", render_mode="rgb_array", **TINY)
    gym_check_env(env.unwrapped)
    sb3_checker.check_env(env.unwrapped, skip_render_check=False)
