"""Task registry: names, lazy classes, errors listing the valid names."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler import TaskSampler
from trossen_arm_mujoco.tasks.task import Task


def test_names():
    assert registry.names() == ["pick_place", "push", "reach", "transfer_cube"]


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
    sampler = registry.make_sampler("reach", command_mode="ee_delta", success_tolerance=0.04)
    try:
        task = sampler.sample_task(0)
        assert task.tolerance == 0.04
        assert sampler.env.robots["wxai"].config.command_mode["arm"] == "ee_delta"
    finally:
        sampler.close()


def test_make_sampler_unknown_command_mode_lists_modes():
    with pytest.raises(UserError, match="joint_position"):
        registry.make_sampler("reach", command_mode="torque")
