"""Checks before a LeRobot export: rates, cameras, rewards, tasks."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.lerobot_plan import plan_export
from trossen_arm_mujoco.tasks import registry

VENDOR = Path(__file__).parents[1] / "fixtures" / "vendor_episode_5steps_4cams.hdf5"


def _episodes(tmp_path, make_episode, specs):
    """Write one episode per ``(task_name, dt)`` and load them."""
    out = []
    for k, (task_name, dt) in enumerate(specs):
        path = tmp_path / f"episode_{k}.hdf5"
        make_episode(path, 3, [], seed=k, task_name=task_name)
        with h5py.File(path, "r+") as f:
            f.attrs["dt"] = np.float64(dt)
        out.append(load_episode(path))
    return out


def test_tasks_rate_and_success_threshold(tmp_path, make_episode):
    eps = _episodes(
        tmp_path,
        make_episode,
        [("sim_insertion", 0.02), ("sim_transfer_cube", 0.02), ("insertion", 0.02)],
    )
    plan = plan_export(eps, None)
    insertion = registry.load("sim_insertion").description
    assert plan.tasks == [insertion, registry.load("sim_transfer_cube").description]
    assert plan.task_index == [0, 1, 0]  # the alias names the same task
    # 30 fps by default (the plugin's loop rate), resampled from the recorded 50
    assert (plan.fps, plan.source_fps) == (30, 50)
    assert plan.with_reward and plan.max_reward == [4.0, 4.0, 4.0]
    assert plan_export(eps, None, fps=50).fps == 50
    assert plan_export(eps, "stack").tasks == ["stack"]


@pytest.mark.parametrize(
    ("specs", "needle"),
    [
        ([("sim_insertion", 0.03)], "33.3333 frames/s; LeRobot datasets need a whole number"),
        ([("sim_insertion", 0.02), ("sim_insertion", 0.04)], "runs at 25 frames/s but"),
        ([("no_such_task", 0.02)], "unknown task 'no_such_task'"),
    ],
)
def test_inconsistent_episodes_are_refused(tmp_path, make_episode, specs, needle):
    with pytest.raises(UserError, match=needle.replace("(", r"\(")):
        plan_export(_episodes(tmp_path, make_episode, specs), None)


def test_vendor_and_recorded_episodes_do_not_mix(tmp_path, make_episode):
    shutil.copy(VENDOR, tmp_path / "episode_9.hdf5")
    vendor = load_episode(tmp_path / "episode_9.hdf5")
    make_episode(tmp_path / "episode_0.hdf5", 5, vendor.camera_names, 0, size=(480, 640))
    ours = load_episode(tmp_path / "episode_0.hdf5")
    with pytest.raises(UserError, match="has rewards but episode_9.hdf5 has none"):
        plan_export([ours, vendor], "x")
    plan = plan_export([vendor], "hand over")
    assert not plan.with_reward and plan.max_reward == [None] and plan.source_fps == 50
