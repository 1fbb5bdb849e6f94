"""The randomization section of task configs: complete with defaults, merged kind by kind,
every kind and parameter checked (one-line errors naming the setting and what is valid)."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks.config import CONFIG_DIR, parse_randomization
from trossen_arm_mujoco.tasks.randomization_schema import (
    RANDOMIZATION_SCHEMA,
    default_randomization,
)
from trossen_arm_mujoco.tasks.registry import load as load_task


def load_task_config(name: str, **overrides):
    """A shipped task's config by its name, validated with its own keys."""
    return load_task(name).load_config(**overrides)


def test_randomization_section_is_complete_and_overrides_merge():
    overrides = {"lights": {"enabled": False}, "friction": {"scale": [0.9, 1.0]}}
    config = load_task_config("push", randomization=overrides)
    section = config["randomization"]
    assert set(section) == set(RANDOMIZATION_SCHEMA)
    assert section["lights"]["enabled"] is False
    assert section["lights"]["direction_deg"] == 15.0  # the YAML value survives
    assert section["friction"]["scale"] == [0.9, 1.0]
    assert load_task_config("push")["randomization"]["lights"]["enabled"] is True


def test_missing_randomization_settings_take_the_defaults():
    assert parse_randomization("x", None) == default_randomization()
    section = parse_randomization("x", {"camera": {"position": 0.02}})
    assert section["camera"] == {"enabled": True, "position": 0.02, "orientation_deg": 1.0}


@pytest.mark.parametrize(
    "section, match",
    [
        ({"light": {}}, "unknown randomization kind 'light'.*lights"),
        ({"lights": {"brightness": 1}}, "setting 'brightness'.*diffuse_scale"),
        (
            {"lights": {"diffuse_scale": [1.4, 0.6]}},
            r"lights.diffuse_scale: expected \[low, high\]",
        ),
        ({"lights": {"diffuse_scale": [0.5]}}, "lights.diffuse_scale"),
        ({"lights": {"ambient": [0.0, 2.0]}}, r"<= 1"),
        ({"friction": {"scale": [0.0, 1.0]}}, "friction.scale"),
        ({"joint_damping": {"range": [-0.1, 0.1]}}, "joint_damping.range"),
        ({"camera": {"position": 0.5}}, r"camera.position: expected a number in \[0, 0.1\]"),
        ({"camera": {"orientation_deg": float("nan")}}, "camera.orientation_deg"),
        ({"joint_noise": {"range": "small"}}, "joint_noise.range"),
        ({"joint_noise": {"enabled": "yes"}}, "joint_noise.enabled: expected true/false"),
        ({"table": {"materials": "maple"}}, "table.materials: expected a list of names"),
        ({"objects": 0.2}, "objects: expected a mapping"),
        ([1, 2], "expected a mapping of kinds"),
    ],
)
def test_bad_randomization_is_a_one_line_error(section, match):
    with pytest.raises(UserError, match=match) as err:
        load_task_config("reach", randomization=section)
    assert "\n" not in str(err.value)


def test_bad_randomization_in_a_yaml_file_is_reported(tmp_path, monkeypatch):
    from trossen_arm_mujoco.tasks import config as config_module

    text = (CONFIG_DIR / "reach.yaml").read_text()
    (tmp_path / "reach.yaml").write_text(text.replace("direction_deg: 15.0", "direction_deg: 120"))
    monkeypatch.setattr(config_module, "CONFIG_DIR", tmp_path)
    match = r"reach.yaml, key randomization.lights.direction_deg: expected a number in \[0, 90\]"
    with pytest.raises(UserError, match=match):
        load_task_config("reach")
