"""Task configs: shipped YAML files, keyword overrides, unknown keys."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.config import CONFIG_DIR, config_names
from trossen_arm_mujoco.tasks.registry import load as load_task

COMMON_KEYS = {
    "scene",
    "policy_dt",
    "ctrl_dt",
    "max_episode_steps",
    "table_height",
    "safety_margin",
    "ee_delta_limit",
    "joint_rel_limit",
    "hold_orientation",
    "workspace_low",
    "workspace_high",
}


def load_task_config(name: str, **overrides):
    """A shipped task's config by its name, validated with its own keys."""
    return load_task(name).load_config(**overrides)


@pytest.mark.parametrize("name", registry.names())
def test_every_task_has_a_yaml_config(name):
    entry = registry.load(name)
    config = entry.load_config()
    if entry.package == "trossen_arm_mujoco":  # an installed package's config is its own
        assert (CONFIG_DIR / f"{entry.config}.yaml").is_file()
        assert COMMON_KEYS <= set(config)


def test_config_dir_is_package_data():
    assert CONFIG_DIR.parent.name == "trossen_arm_mujoco"
    assert set(config_names()) >= {"reach", "push", "pick_place", "transfer_cube"}


def test_override_replaces_value():
    config = load_task_config("reach", success_tolerance=0.05, target_low=[0.2, -0.1, 0.1])
    assert config["success_tolerance"] == 0.05
    assert config["target_low"] == [0.2, -0.1, 0.1]
    assert load_task_config("reach")["success_tolerance"] == 0.025


def test_int_override_of_float_key_becomes_float():
    assert load_task_config("reach", table_height=0)["table_height"] == 0.0


def test_unknown_key_lists_valid_keys():
    with pytest.raises(UserError) as err:
        load_task_config("reach", succes_tolerance=0.05)
    msg = str(err.value)
    assert "succes_tolerance" in msg and "success_tolerance" in msg and "target_low" in msg
    assert "\n" not in msg


@pytest.mark.parametrize(
    "key, value",
    [
        ("success_tolerance", "big"),
        ("target_low", [0.1, 0.2]),
        ("max_episode_steps", 10.5),
        ("hold_orientation", 1),
    ],
)
def test_wrong_kind_of_value_is_rejected(key, value):
    with pytest.raises(UserError, match=key):
        load_task_config("reach", **{key: value})


def test_unknown_config_name_lists_names():
    with pytest.raises(UserError, match="reach"):
        load_task_config("reech")
