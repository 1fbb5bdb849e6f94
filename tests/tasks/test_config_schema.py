"""The one validation layer of task configs (``tasks.config_schema``): every YAML key and every
keyword override checked for kind and range (NaN, inf, negative tolerances, inverted ranges,
whole numbers), unknown and duplicate keys refused; each problem one line naming the file (or
keyword argument) and the key."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import config as config_module
from trossen_arm_mujoco.tasks.config import CONFIG_DIR, config_names
from trossen_arm_mujoco.tasks.config_schema import KEYS, REQUIRED, range_pairs
from trossen_arm_mujoco.tasks.registry import load as load_task


def load_task_config(name: str, **overrides):
    """A shipped task's config by its name, validated with its own keys."""
    return load_task(name).load_config(**overrides)


@pytest.fixture
def broken_reach(tmp_path, monkeypatch):
    """``broken_reach(old, new)``: a temp copy of the config dir, read by the loader, whose
    reach.yaml has ``old`` replaced by ``new``; returns that file's path."""
    copy = tmp_path / "config"
    shutil.copytree(CONFIG_DIR, copy)
    monkeypatch.setattr(config_module, "CONFIG_DIR", copy)

    def _break(old: str, new: str):
        path = copy / "reach.yaml"
        text = path.read_text()
        assert old in text, old
        path.write_text(text.replace(old, new, 1))
        return path

    return _break


def _one_line_error(match: str, **overrides) -> str:
    with pytest.raises(UserError, match=match) as err:
        load_task_config("reach", **overrides)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


# --- the shipped files ----------------------------------------------------------------------
@pytest.mark.parametrize("name", config_names())
def test_every_shipped_config_passes_and_has_only_schema_keys(name):
    from trossen_arm_mujoco.tasks import registry

    # every shipped config is a shipped task's, whose own keys are in its TaskEntry
    entries = [registry.load(n) for n in registry.names()]
    entry = next(e for e in entries if e.config == name)
    config = entry.load_config()
    assert load_task_config(name) == config  # by config name: the same keys apply
    assert set(config) - {"randomization"} <= set(KEYS) | set(entry.keys)
    assert set(REQUIRED) | set(entry.required) <= set(config)
    assert set(entry.required) <= set(KEYS) | set(entry.keys)
    for low, high in range_pairs(config):
        assert all(a <= b for a, b in zip(config[low], config[high], strict=True))


def test_the_schema_lists_only_keys_every_task_shares():
    """A task's own keys live in its TaskEntry, not in the schema (issue 38: a task declares
    its facts in one place): the keys of one task, or of one family of tasks, are not in KEYS."""
    from trossen_arm_mujoco.tasks import registry

    entries = [
        registry.load(n)
        for n in registry.names()
        if registry.load(n).package == "trossen_arm_mujoco"
    ]
    for key in (
        "target_low",
        "cube_low",
        "goal_low",
        "lift_height",
        "air_goal_probability",
        "init_arm_qpos",
        "success_tolerance",
    ):
        assert key not in KEYS
        assert any(key in e.keys for e in entries), key


def test_range_pairs_are_found_by_name():
    assert range_pairs(["cube_low", "cube_high", "goal_low", "workspace_high", "x"]) == [
        ("cube_low", "cube_high")
    ]


def test_yaml_values_are_converted_to_their_kind():
    config = load_task_config("reach")
    assert type(config["max_episode_steps"]) is int
    assert type(config["table_height"]) is float
    assert all(type(v) is float for v in config["target_low"])


# --- broken YAML files: file, key, reason in one line ---------------------------------------
TOL = "success_tolerance: 0.025"
#: what success_tolerance accepts, as a regex
TOL_OK = r"success_tolerance: expected a number in \(0, 1\] m"


@pytest.mark.parametrize(
    "old, new, match",
    [
        (TOL, "success_tolerance: .nan", TOL_OK + ", got nan"),
        (TOL, "success_tolerance: .inf", TOL_OK + ", got inf"),
        (TOL, "success_tolerance: -.inf", "success_tolerance: expected .*got -inf"),
        (TOL, "success_tolerance: -0.01", TOL_OK + ", got -0.01"),
        (TOL, "success_tolerance: 0", r"success_tolerance: expected a number in \(0, 1\]"),
        (TOL, "success_tolerance: small", "success_tolerance: expected a number .*got 'small'"),
        (TOL, "success_tolerance: [0.1]", "success_tolerance: expected a number .*got \\[0.1\\]"),
        (TOL, "success_tolerance: true", "success_tolerance: expected a number .*got True"),
        (TOL, "success_tolerance:", "success_tolerance: expected a number .*got None"),
        (
            "max_episode_steps: 50",
            "max_episode_steps: 50.5",
            r"max_episode_steps: expected a whole number in \[1, 10000000\], got 50.5",
        ),
        ("max_episode_steps: 50", "max_episode_steps: 0", "max_episode_steps: expected a whole"),
        ("max_episode_steps: 50", "max_episode_steps: '50'", "max_episode_steps: .*got '50'"),
        (
            "target_low: [0.18, -0.22, 0.06]",
            "target_low: [0.5, -0.22, 0.06]",
            "target_low/target_high: expected target_low <= target_high on every axis, "
            "got 0.5 > 0.42 on axis 0",
        ),
        (
            "workspace_high: [0.8, 0.8, 0.9]",
            "workspace_high: [0.8, 0.8, -0.5]",
            "workspace_low/workspace_high: .*-0.1 > -0.5 on axis 2",
        ),
        (
            "target_low: [0.18, -0.22, 0.06]",
            "target_low: [0.18, -0.22]",
            r"target_low: expected a list of 3 numbers, each in \[-10, 10\] m",
        ),
        ("target_low: [0.18, -0.22, 0.06]", "target_low: [0.1, .nan, 0.1]", "target_low: expected"),
        ("target_low: [0.18, -0.22, 0.06]", "target_low: 0.18", "target_low: expected a list"),
        ("hold_orientation: false", "hold_orientation: 0", "hold_orientation: expected true/false"),
        (
            "goal_reward_type: sparse",
            "goal_reward_type: sparce",
            "goal_reward_type: expected one of sparse, dense, got 'sparce'",
        ),
        ("safety_margin: 0.02", "safety_margin: .nan", r"safety_margin: .* \[0, 0.5\] m, got nan"),
        ("table_height: 0.0", "table_height: .nan", r"table_height: .* in \[-1, 2\] m, got nan"),
        ("scene: wxai/scene_reach.xml", "scene: ''", "scene: expected a non-empty string"),
        ("safety_margin: 0.02", "safety_margin: {a: 1}", "safety_margin: expected a number"),
        ("direction_deg: 15.0", "direction_deg: .nan", "randomization.lights.direction_deg: exp"),
    ],
)
def test_bad_value_in_a_file_names_file_and_key(broken_reach, old, new, match):
    path = broken_reach(old, new)
    with pytest.raises(UserError, match=match) as err:
        load_task_config("reach")
    msg = str(err.value)
    assert msg.startswith(f"config file {path}, key ") and "\n" not in msg


def test_unknown_key_in_a_file_is_refused(broken_reach):
    path = broken_reach("distance_coef: 1.0", "distance_coef: 1.0\ndistanse_coef: 1.0")
    with pytest.raises(UserError) as err:
        load_task_config("reach")
    msg = str(err.value)
    assert msg.startswith(f"config file {path}, key distanse_coef: unknown key")
    assert "did you mean distance_coef?" in msg and "success_tolerance" in msg
    assert "\n" not in msg


@pytest.mark.parametrize(
    "old, new, key, again",
    [
        (
            "distance_coef: 1.0",
            "distance_coef: 1.0\ndistance_coef: 2.0",
            "distance_coef",
            "distance_coef: 2.0",
        ),
        (
            "    enabled: true\n",
            "    enabled: true\n    enabled: false\n",
            "randomization.lights.enabled",
            "    enabled: false",
        ),
    ],
)
def test_duplicate_key_in_a_file_is_refused(broken_reach, old, new, key, again):
    """PyYAML alone would keep the last value silently."""
    path = broken_reach(old, new)
    line = path.read_text().splitlines().index(again) + 1  # the first one is just above
    with pytest.raises(UserError) as err:
        load_task_config("reach")
    assert str(err.value) == (
        f"config file {path}, key {key}: given twice (lines {line - 1} and {line}); keep one"
    )


def test_missing_key_is_named(broken_reach):
    path = broken_reach("success_tolerance: 0.025   # m, distance tool frame -> target\n", "")
    with pytest.raises(UserError, match="missing key.*success_tolerance") as err:
        load_task_config("reach")
    assert str(err.value).startswith(f"config file {path}: ")


@pytest.mark.parametrize(
    "old, new, match",
    [
        (
            "scene: wxai/scene_reach.xml",
            "scene: [wxai/scene_reach.xml",
            "cannot parse YAML at line 4: expected ',' or ']'",
        ),
        ("policy_dt: 0.02", "policy_dt: 0.02\n  bad indent: 1", "cannot parse YAML at line"),
        ("policy_dt: 0.02", "policy_dt: !!python/object:os.system x", "cannot parse YAML"),
    ],
)
def test_malformed_yaml_is_one_line(broken_reach, old, new, match):
    path = broken_reach(old, new)
    with pytest.raises(UserError, match=match) as err:
        load_task_config("reach")
    assert str(err.value).startswith(f"config file {path}: ") and "\n" not in str(err.value)


def test_a_file_that_is_not_a_mapping_is_refused(broken_reach):
    path = broken_reach("scene:", "- scene:")
    path.write_text("- 1\n- 2\n")
    with pytest.raises(UserError, match="expected a mapping of keys to values, got list"):
        load_task_config("reach")


def test_exponent_without_dot_is_a_number(broken_reach):
    """YAML 1.1 (PyYAML) reads 1e-3 as a string; the config loader reads it as YAML 1.2."""
    broken_reach(TOL, "success_tolerance: 1e-3")
    assert load_task_config("reach")["success_tolerance"] == 0.001


def test_a_broken_file_breaks_only_its_task(broken_reach):
    broken_reach(TOL, "success_tolerance: .nan")
    with pytest.raises(UserError):
        load_task_config("reach")
    assert load_task_config("push")["success_tolerance"] == 0.03


# --- keyword overrides (make_sampler, gym kwargs) -------------------------------------------
@pytest.mark.parametrize(
    "overrides, match",
    [
        ({"success_tolerance": math.nan}, TOL_OK + ", got nan"),
        ({"success_tolerance": -0.01}, r"success_tolerance: expected a number in \(0, 1\] m"),
        ({"success_tolerance": math.inf}, "success_tolerance: .*got inf"),
        ({"table_height": math.nan}, r"table_height: expected a number in \[-1, 2\] m, got nan"),
        ({"safety_margin": math.nan}, r"safety_margin: expected a number in \[0, 0.5\] m, got nan"),
        ({"safety_margin": -0.01}, r"safety_margin: expected a number in \[0, 0.5\] m"),
        ({"ee_delta_limit": -0.1}, r"ee_delta_limit: expected a number in \(0, 0.5\] m"),
        ({"joint_rel_limit": math.inf}, "joint_rel_limit: expected"),
        ({"init_joint_noise": -0.1}, r"init_joint_noise: expected a number in \[0, 1\] rad"),
        ({"distance_coef": math.nan}, "distance_coef: expected a number >= 0"),
        ({"max_episode_steps": 50.5}, r"max_episode_steps: expected a whole number in \[1, 1000"),
        ({"max_episode_steps": True}, "max_episode_steps: expected a whole number"),
        ({"max_episode_steps": "50"}, "max_episode_steps: expected a whole number"),
        (
            {"workspace_low": [1.0, 1.0, 1.0]},
            "workspace_low/workspace_high: expected workspace_low <= workspace_high on every axis",
        ),
        (
            {"target_low": [0.3, 0.0, 0.2], "target_high": [0.2, 0.1, 0.3]},
            "target_low/target_high: .*0.3 > 0.2 on axis 0",
        ),
        (
            {"target_low": [0.1, 0.2]},
            r"target_low: expected a list of 3 numbers \(as in the task's",
        ),
        ({"target_low": [0.1, math.nan, 0.2]}, "target_low: expected a list of 3 numbers"),
        ({"target_low": "0.1 0.2 0.3"}, "target_low: expected a list"),
        ({"hold_orientation": 1}, "hold_orientation: expected true/false, got 1"),
        ({"goal_reward_type": "Sparse"}, "goal_reward_type: expected one of sparse, dense"),
    ],
)
def test_bad_override_names_the_keyword_argument_and_valid_range(overrides, match):
    msg = _one_line_error(match, **overrides)
    assert msg.startswith("task config 'reach', keyword argument ")


def test_unknown_override_lists_the_valid_keys():
    msg = _one_line_error("succes_tolerance", succes_tolerance=0.05)
    assert "success_tolerance" in msg and "target_low" in msg


def test_numpy_values_are_accepted_and_converted():
    config = load_task_config(
        "reach",
        success_tolerance=np.float32(0.05),
        max_episode_steps=np.int64(7),
        hold_orientation=np.bool_(True),
        target_low=np.array([0.2, -0.1, 0.1]),
        max_joint_velocity=np.float64(10.0),
    )
    assert type(config["success_tolerance"]) is float and config["max_episode_steps"] == 7
    assert config["hold_orientation"] is True and config["target_low"] == [0.2, -0.1, 0.1]
    assert type(config["max_episode_steps"]) is int
    assert load_task_config("reach", max_episode_steps=40.0)["max_episode_steps"] == 40


def test_equal_low_and_high_is_a_fixed_spawn():
    low = [0.3, 0.0, 0.2]
    config = load_task_config("reach", target_low=low, target_high=low)
    assert config["target_low"] == config["target_high"] == low


def test_a_valid_override_does_not_blame_the_file_or_other_pairs():
    config = load_task_config("push", goal_low=[0.3, -0.1], goal_high=[0.35, 0.1])
    assert config["goal_low"] == [0.3, -0.1]


def test_huge_integers_are_out_of_range_not_a_crash():
    with pytest.raises(UserError, match="max_episode_steps"):
        load_task_config("reach", max_episode_steps=10**400)
