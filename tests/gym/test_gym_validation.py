"""The gym env's keyword arguments checked once, at construction (NaN safety floor, negative
tolerances, inverted ranges, image sizes, ...), each a one-line UserError naming the
argument and what is valid; ``step``/``render`` after ``close`` a one-line UserError."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.actions import ActionMapper
from trossen_arm_mujoco.gym.env import TrossenMujocoEnv
from trossen_arm_mujoco.gym.goal_env import TrossenMujocoGoalEnv
from trossen_arm_mujoco.gym.spaces import ObservationBuilder
from trossen_arm_mujoco.robot.safety_floor import SafetyFloor

REACH = "TrossenMujoco/WXAIReach-v0"
PUSH = "TrossenMujoco/WXAIPush-v0"
KWARG = "task config '{task}', keyword argument "


def _refused(make_env, env_id: str, match: str, **kwargs) -> str:
    with pytest.raises(UserError, match=match) as err:
        make_env(env_id, **kwargs)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"table_height": math.nan}, r"table_height: expected a number in \[-1, 2\] m, got nan"),
        ({"safety_margin": math.nan}, r"safety_margin: expected a number in \[0, 0.5\] m, got nan"),
        ({"safety_margin": -0.02}, r"safety_margin: expected a number in \[0, 0.5\] m, got -0.02"),
        ({"table_height": math.inf}, "table_height: expected .*got inf"),
        ({"success_tolerance": -0.01}, r"success_tolerance: expected a number in \(0, 1\] m"),
        ({"success_tolerance": math.nan}, "success_tolerance: expected .*got nan"),
        ({"ee_delta_limit": 0.0}, r"ee_delta_limit: expected a number in \(0, 0.5\] m, got 0.0"),
        ({"joint_rel_limit": -0.1}, r"joint_rel_limit: expected a number in \(0, 3.14159\] rad"),
        ({"max_joint_velocity": math.nan}, "max_joint_velocity: expected"),
        (
            {"workspace_low": [0.9, -0.8, -0.1]},
            "workspace_low/workspace_high: expected workspace_low <= workspace_high on every "
            "axis, got 0.9 > 0.8 on axis 0",
        ),
        (
            {"target_low": [0.3, 0.3, 0.3], "target_high": [0.2, 0.4, 0.4]},
            "target_low/target_high: .*0.3 > 0.2 on axis 0",
        ),
        ({"target_low": [0.2, math.nan, 0.1]}, "target_low: expected a list of 3 numbers"),
        ({"goal_reward_type": "shaped"}, "goal_reward_type: expected one of sparse, dense"),
        ({"hold_orientation": "yes"}, "hold_orientation: expected true/false"),
    ],
)
def test_bad_config_kwarg_is_one_line_naming_it_and_the_valid_range(make_env, kwargs, match):
    msg = _refused(make_env, REACH, match, **kwargs)
    assert msg.startswith(KWARG.format(task="reach"))


def test_push_spawn_ranges_are_ordered(make_env):
    _refused(make_env, PUSH, "cube_low/cube_high: .*0.4 > 0.38 on axis 0", cube_low=[0.4, -0.12])
    _refused(make_env, PUSH, "goal_low/goal_high: ", goal_high=[0.42, -0.2])


def test_whole_number_steps_through_the_env_class():
    """``gym.make(max_episode_steps=...)`` is gymnasium's own; the class takes the key."""
    with pytest.raises(UserError, match=r"max_episode_steps: expected a whole number .*50.5"):
        TrossenMujocoEnv("reach", max_episode_steps=50.5)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"width": 0}, r"width: expected a whole number in \[1, 16384\], got 0"),
        ({"height": 24.5}, "height: expected a whole number"),
        ({"width": math.nan}, "width: expected a whole number"),
        ({"height": "64"}, "height: expected a whole number"),
        ({"randomize": "yes"}, "randomize: expected true/false"),
        ({"cameras": 3}, "cameras: expected a camera name or a list of them"),
        ({"cameras": ["overview", None]}, "cameras: expected a camera name"),
        ({"obs_type": ["state"]}, "unknown observation type"),
        ({"shadows": "no"}, "shadows must be True or False"),
    ],
)
def test_bad_env_option_is_one_line(make_env, kwargs, match):
    _refused(make_env, REACH, match, **kwargs)


def test_whole_float_image_size_is_accepted(make_env):
    env = make_env(REACH, width=32.0, height=np.int64(24))
    assert env.unwrapped.observations.image_space.shape == (24, 32, 3)


def test_goal_env_checks_its_kwargs_too():
    with pytest.raises(UserError, match="success_tolerance: expected .*got -0.5"):
        TrossenMujocoGoalEnv("push", success_tolerance=-0.5)


# --- the layers below the env check what they are given, at construction ------------------
def test_nan_floor_is_refused_by_the_safety_floor_itself():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(UserError, match="safety floor height must be a finite number"):
        SafetyFloor(model, [], floor_z=math.nan)


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("joint_rel_limit", math.nan, "joint_rel_limit: expected .*got nan"),
        ("ee_delta_limit", -0.1, "ee_delta_limit: expected"),
        ("joint_rel_limit", -0.1, "joint_rel_limit: expected"),
    ],
)
def test_action_mapper_refuses_a_bad_config(make_env, key, value, match):
    env = make_env(REACH).unwrapped
    arms = env.sampler.arms
    config = {**env.config, key: value}
    with pytest.raises(UserError, match=match):
        ActionMapper(env.actions.robot, arms, "joint_position", config)
    del config[key]
    with pytest.raises(UserError, match=f"no key {key}"):
        ActionMapper(env.actions.robot, arms, "joint_position", config)


def test_observation_bounds_must_be_finite_and_ordered(make_env):
    from trossen_arm_mujoco.tasks.observation import Part
    from trossen_arm_mujoco.tasks.reach import ReachTask

    env = make_env(REACH).unwrapped
    probe = env.probe

    class Inverted(ReachTask):
        def observation_parts(self):
            parts = super().observation_parts()
            return [*parts[:-1], Part("ee_pos", parts[-1].value, 1.0, 0.0)]

    inverted = Inverted(env.scene, env.config)
    with pytest.raises(UserError, match="observation entry 'ee_pos': bounds must be finite"):
        ObservationBuilder(inverted, "state", False, 0, 8, 8)
    with pytest.raises(UserError, match="observation width must be a whole number"):
        ObservationBuilder(probe, "state", False, 0, 8, 8.5)


# --- after close ------------------------------------------------------------------------------
def test_step_after_close_is_a_one_line_error(make_env):
    env = make_env(REACH)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
    with pytest.raises(UserError) as err:
        env.step(env.action_space.sample())
    assert str(err.value) == "this env is closed; call reset() to reopen it (or make a new one)"
    env.close()  # twice: harmless


def test_render_after_close_is_a_one_line_error_and_reset_reopens(make_env):
    env = make_env(REACH, obs_type="pixels", render_mode="rgb_array", width=16, height=16)
    env.reset(seed=0)
    env.close()
    with pytest.raises(UserError, match="this env is closed"):
        env.render()
    obs, _ = env.reset(seed=0)  # reopened: renderers are made again
    assert obs.shape == (16, 16, 3) and env.render().shape == (16, 16, 3)
    env.step(env.action_space.sample())


def test_step_before_reset_still_says_so():
    env = TrossenMujocoEnv("reach")
    try:
        with pytest.raises(UserError, match=r"call reset\(\) before step\(\)"):
            env.step(np.zeros(env.action_space.shape))
    finally:
        env.close()
