"""Task registry: names, lazy classes, errors listing the valid names."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import LAYOUTS
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler import TaskSampler
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.task import Task


def test_names():
    shipped = [n for n in registry.names() if registry.load(n).package == "trossen_arm_mujoco"]
    assert shipped == [
        "mobile_pick_place",
        "pick_place",
        "push",
        "reach",
        "sim_insertion",
        "sim_transfer_cube",
    ]
    assert registry.names() == sorted(registry.TASKS)  # installed packages' tasks included


def test_old_names_are_aliases():
    assert registry.load("transfer_cube") is registry.load("sim_transfer_cube")
    assert registry.canonical("transfer_cube") == "sim_transfer_cube"


def test_sim_task_configs_are_derived_from_the_registry():
    from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS

    assert SIM_TASK_CONFIGS == registry.sim_task_configs()
    assert set(SIM_TASK_CONFIGS) == set(registry.scripted_names())
    assert SIM_TASK_CONFIGS["sim_transfer_cube"] == {
        "num_episodes": 1,
        "episode_len": 600,
        "onscreen_render": False,
        "inject_noise": False,
        "cam_names": ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"],
    }


@pytest.mark.parametrize("name", registry.scripted_names())
def test_scripted_entries_have_policy_and_ee_flavour(name):
    entry = registry.load(name)
    policy = entry.policy_class()
    assert policy.minimum_episode_len <= entry.record["episode_len"]
    layout = getattr(policy, "action_layout", "ee")
    if layout == "ee":  # an end-effector policy: record's mocap rollout, then the joint replay
        assert callable(policy) and hasattr(policy, "generate_trajectory")
        assert "ee_scene" in entry.load_config()
    elif layout == "arm_ee":  # one arm's tool poses: IK rollout, then the joint replay
        assert callable(policy) and hasattr(policy, "plan")
        assert len(entry.sampler_class().arms) == 1
    else:  # a joint policy (the Mobile AI's): recorded as it acts, in a layout of LAYOUTS
        assert layout in LAYOUTS and callable(policy)


def test_task_without_policy_says_so():
    with pytest.raises(UserError, match="no scripted policy"):
        registry.load("reach").policy_class()


def test_unknown_name_lists_valid_names():
    with pytest.raises(UserError) as err:
        registry.load("transfer")
    msg = str(err.value)
    assert "transfer" in msg
    for name in registry.names():
        assert name in msg


@pytest.mark.parametrize("name", registry.names())
def test_entries_resolve_to_classes(name):
    entry = registry.load(name)
    assert issubclass(entry.task_class(), Task)
    assert issubclass(entry.sampler_class(), TaskSampler)
    assert entry.sampler_class().task_cls is entry.task_class()
    assert entry.task_class().name == name


def test_make_sampler_applies_overrides():
    sampler = registry.make_sampler(
        "reach", SamplerSettings(command_mode="ee_delta"), success_tolerance=0.04
    )
    try:
        task = sampler.sample_task(0)
        assert task.tolerance == 0.04
        assert sampler.scene.robots["wxai"].config.command_mode["arm"] == "ee_delta"
    finally:
        sampler.close()


def test_make_sampler_unknown_command_mode_lists_modes():
    with pytest.raises(UserError, match="joint_position"):
        registry.make_sampler("reach", SamplerSettings(command_mode="torque"))
