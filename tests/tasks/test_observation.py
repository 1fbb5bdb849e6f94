"""Observation parts (tasks/observation.py): live views and computed values, the dict,
bounds and values derived from one list, checks, ``indexed`` and ``joined``; and the tasks'
parts: live views of ``MjData`` that follow the simulation, the goals read from them."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.observation import ObservationParts, Part, indexed, joined
from trossen_arm_mujoco.tasks.single_arm import goal_distance

TWO_CUBES = """
<mujoco>
  <worldbody>
    <body name="a"><freejoint name="a"/><geom size=".1"/></body>
    <body name="b" pos="1 0 0"><freejoint name="b"/><geom size=".1"/></body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def data():
    model = mujoco.MjModel.from_xml_string(TWO_CUBES)
    d = mujoco.MjData(model)
    d.qpos[:] = np.arange(model.nq, dtype=float)
    return d


def test_a_live_part_follows_the_data_and_is_read_only(data):
    part = Part("a_pos", data.qpos[0:3], -10.0, 10.0)
    assert part.live and part.size == 3
    data.qpos[0:3] = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(part.read(), [1.0, 2.0, 3.0])
    assert np.shares_memory(part.read(), data.qpos)
    with pytest.raises(ValueError, match="read-only"):
        part.read()[0] = 5.0
    data.qpos[0] = 7.0  # the data itself stays writable
    assert part.read()[0] == 7.0


def test_a_computed_part_is_called_at_each_read(data):
    part = Part("height", lambda: data.qpos[2:3] * 2.0, [0.0], [5.0])
    assert not part.live and part.size == 1
    data.qpos[2] = 1.5
    np.testing.assert_array_equal(part.read(), [3.0])


def test_scalar_bounds_are_broadcast(data):
    live = Part("v", data.qvel[0:6], -2.0, 2.0)
    np.testing.assert_array_equal(live.low, np.full(6, -2.0))
    computed = Part("c", lambda: np.zeros(4), np.zeros(4), 1.0)
    np.testing.assert_array_equal(computed.high, np.ones(4))
    with pytest.raises(UserError, match="part 'v': bounds of 2 and 6 values for 6 values"):
        _ = Part("v", data.qvel[0:6], [-1.0, -1.0], 1.0).low  # checked when first used


def test_a_value_must_be_an_array_or_a_callable():
    with pytest.raises(UserError, match="part 'x': the value must be an array"):
        Part("x", [1.0, 2.0], 0.0, 1.0)


def test_bounds_are_copied(data):
    low = np.zeros(3)
    part = Part("p", data.qpos[0:3], low, 10.0)
    low[:] = 5.0
    np.testing.assert_array_equal(part.low, np.zeros(3))


def test_dict_bounds_and_values_come_from_one_list(data):
    observed = ObservationParts(
        [
            Part("a", data.qpos[0:7], -100.0, 100.0),
            Part("twice", lambda: 2.0 * data.qpos[7:9], np.full(2, -100.0), 100.0),
        ]
    )
    assert observed.names == ("a", "twice") and observed.size == 9 and len(observed) == 2
    obs = observed.as_dict()
    np.testing.assert_array_equal(obs["a"], np.arange(7.0))
    np.testing.assert_array_equal(obs["twice"], [14.0, 16.0])
    assert not np.shares_memory(obs["a"], data.qpos)  # the dict holds copies
    values = observed.values()
    assert np.shares_memory(values[0], data.qpos)  # the vector's pieces: views, no copies
    np.testing.assert_array_equal(np.concatenate(values), np.concatenate(list(obs.values())))
    low, high = observed.low_high()
    assert low.shape == high.shape == (9,)
    bounds = observed.bounds()
    bounds["a"][0][:] = 0.0  # copies
    assert observed["a"].low[0] == -100.0
    assert "a" in observed and "b" not in observed
    np.testing.assert_array_equal(observed.read("twice"), [14.0, 16.0])


def test_parts_are_checked_with_a_line_naming_the_part(data):
    with pytest.raises(UserError, match="part 'a' is declared twice"):
        ObservationParts([Part("a", data.qpos[0:1], 0, 1), Part("a", data.qpos[1:2], 0, 1)])
    inverted = ObservationParts([Part("a", data.qpos[0:1], 0, 1), Part("b", data.qpos[1:2], 1, 0)])
    inverted.values()  # reading never needs the bounds
    with pytest.raises(UserError, match="entry 'b': bounds must be finite with low <= high"):
        inverted.bounds()  # checked when first used
    with pytest.raises(UserError, match="entry 'c': bounds must be finite"):
        ObservationParts([Part("c", data.qpos[0:1], -np.inf, 1)]).low_high()
    with pytest.raises(UserError, match="must be Part objects"):
        ObservationParts([("a", data.qpos)])
    with pytest.raises(UserError, match="no observation part 'z'; the parts are: a"):
        ObservationParts([Part("a", data.qpos[0:1], 0, 1)])["z"]


def test_indexed_gives_a_view_for_evenly_spaced_indices(data):
    view = indexed(data.qpos, [2, 3, 4])
    assert isinstance(view, np.ndarray) and np.shares_memory(view, data.qpos)
    np.testing.assert_array_equal(view, [2.0, 3.0, 4.0])
    strided = indexed(data.qpos, [0, 2, 4])
    assert isinstance(strided, np.ndarray)
    np.testing.assert_array_equal(strided, [0.0, 2.0, 4.0])
    scattered = indexed(data.qpos, [0, 1, 5])
    assert callable(scattered)
    data.qpos[5] = 50.0
    np.testing.assert_array_equal(scattered(), [0.0, 1.0, 50.0])
    assert indexed(data.qpos, []).size == 0


def test_joined_views_become_one_view_when_they_touch(data):
    a, b = data.qpos[0:7], data.qpos[7:14]
    both = joined([a, b])
    assert isinstance(both, np.ndarray) and np.shares_memory(both, data.qpos)
    np.testing.assert_array_equal(both, np.arange(14.0))
    data.qpos[8] = -1.0
    assert both[8] == -1.0
    apart = joined([data.qpos[0:3], data.qpos[7:10]])
    assert callable(apart)
    np.testing.assert_array_equal(apart(), [0.0, 1.0, 2.0, 7.0, -1.0, 9.0])
    other = joined([data.qpos[0:7], data.qvel[0:6]])  # other arrays: never one view
    assert callable(other) and other().shape == (13,)
    assert joined([]).size == 0 and joined([a]) is a


# --- the tasks' parts ------------------------------------------------------------------------
@pytest.mark.parametrize("name", registry.names())
def test_task_parts_are_live_views_that_follow_the_simulation(name):
    """Every part of the built-in tasks except push's cube_rel is a live view of data; views
    taken before the steps still give get_observation's values after them."""
    s = registry.make_sampler(name)
    try:
        task = s.sample_task(3)
        parts = task.observed.values()
        computed = [p.name for p in task.observed if not p.live]
        assert computed == (["cube_rel"] if name in ("push", "pick_place") else [])
        for _ in range(4):
            task.step({})
            obs = task.get_observation()
            for part, before, (key, want) in zip(task.observed, parts, obs.items()):
                assert part.name == key
                if part.live:
                    np.testing.assert_array_equal(before, want)
            np.testing.assert_array_equal(
                np.concatenate(task.observed.values()), np.concatenate(list(obs.values()))
            )
            if task.goal_conditioned:
                achieved, desired = task.goals
                np.testing.assert_array_equal(task.achieved_goal(), achieved.read())
                np.testing.assert_array_equal(task.desired_goal(), task.goal)
                want = float(goal_distance(task.achieved_goal(), task.desired_goal()))
                assert task.distance() == want
    finally:
        s.close()


def test_goals_of_the_single_arm_tasks_are_observation_parts():
    for name, achieved in (("reach", "ee_pos"), ("push", "cube_pos"), ("pick_place", "cube_pos")):
        s = registry.make_sampler(name)
        try:
            task = s.sample_task(0)
            assert task.goals[0] is task.observed[achieved]
            assert task.goals[1].name == "goal" and task.goals[1].live
            low, high = task.goal_bounds()
            np.testing.assert_array_equal(low, task.ws_low)
            np.testing.assert_array_equal(high, task.ws_high)
        finally:
            s.close()


def test_a_task_class_defining_a_derived_method_is_refused():
    from trossen_arm_mujoco.tasks.reach import ReachTask

    with pytest.raises(UserError, match="defines get_observation\\(\\); declare"):

        class Observed(ReachTask):
            def get_observation(self):
                return {}

    with pytest.raises(UserError, match="defines achieved_goal\\(\\)"):

        class Shifted(ReachTask):
            def achieved_goal(self):
                return np.zeros(3)
