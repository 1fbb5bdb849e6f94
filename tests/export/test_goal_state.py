"""A goal-conditioned single-arm episode exported with ``--sim_features``: the goal after the
object poses in ``observation.environment_state`` and ``next.success`` as the task judges it
(the cube's centre within the task's tolerance of the goal); tasks whose goal is not an
object's centre are not judged that way; a damaged goal is one line."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.goal_state import GOAL_NAMES, episode_goal, goal_judge
from trossen_arm_mujoco.tasks import registry


def _episode(goal) -> SimpleNamespace:
    return SimpleNamespace(attrs={"goal": goal}, path=Path("episode_3.hdf5"))


def test_the_pick_place_goal_is_judged_on_the_cubes_centre():
    entry = registry.load("pick_place")
    judge = goal_judge(entry, ["cube"])
    tolerance = entry.load_config()["success_tolerance"]
    assert judge is not None and (judge.index, judge.tolerance) == (0, tolerance)
    goal = np.array([0.3, 0.0, 0.1])
    poses = np.zeros((3, 7))
    poses[:, :3] = goal
    poses[0, 0] += 2 * tolerance  # far
    poses[1, 0] += 0.5 * tolerance  # within
    np.testing.assert_array_equal(judge.success(poses, goal), [False, True, True])
    # the reach task's achieved goal is the tool, not an object: not judged from poses
    assert goal_judge(registry.load("reach"), []) is None
    assert goal_judge(registry.load("transfer_cube"), ["red_box"]) is None  # no goal
    assert goal_judge(None, ["cube"]) is None  # a vendor recording


@pytest.mark.parametrize("goal", [[0.1, 0.2], [0.1, float("nan"), 0.0], "far"])
def test_a_damaged_goal_is_one_line_naming_the_file(goal):
    with pytest.raises(UserError, match=r"^episode_3.hdf5: its goal attribute is not 3 finite"):
        episode_goal(_episode(goal))
    assert episode_goal(SimpleNamespace(attrs={}, path=Path("e.hdf5"))) is None


def test_a_recorded_pick_place_exports_its_goal_and_success(tmp_path):
    pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    from trossen_arm_mujoco.data.reader import load_episode
    from trossen_arm_mujoco.scripts.export_dataset import cli
    from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli

    data = tmp_path / "eps"
    args = ["--task_name", "pick_place", "--data_dir", str(data), "--num_episodes", "1"]
    assert record_cli([*args, "--cam_names", "none"]) == 0
    ep = load_episode(data / "episode_0.hdf5")
    base = ["--data_dir", str(data), "--repo_id", "me/arm", "--fps", "50"]
    assert cli([*base, "--output", str(tmp_path / "sim"), "--sim_features"]) == 0
    info = json.loads((tmp_path / "sim/meta/info.json").read_text())
    names = info["features"]["observation.environment_state"]["names"]
    assert names[7:] == list(GOAL_NAMES) and names[0] == "cube_x" and len(names) == 10
    table = pq.read_table(next((tmp_path / "sim/data").rglob("*.parquet"))).to_pydict()
    state = np.array(table["observation.environment_state"])
    np.testing.assert_allclose(state[:, 7:], np.tile(ep.attrs["goal"], (len(state), 1)), 1e-6)
    tolerance = registry.load("pick_place").load_config()["success_tolerance"]
    near = np.linalg.norm(state[:, :3] - state[:, 7:], axis=1) < tolerance
    success = np.array(table["next.success"])
    np.testing.assert_array_equal(success, near)
    assert success[-1] and not success[0]  # the recorded episode succeeded; it starts apart
    # the default export is what the plugin records: no environment_state, no success
    assert cli([*base, "--output", str(tmp_path / "plain")]) == 0
    plain = json.loads((tmp_path / "plain/meta/info.json").read_text())["features"]
    assert "observation.environment_state" not in plain and "next.success" not in plain
