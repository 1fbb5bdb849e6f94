"""What the single-arm wxai tasks share (tasks/single_arm.py), through the reach and push
tasks: goal distance, default goal, goal marker, robot observation and bounds, success and
reward against the tolerance, initial joints and their seeded noise."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.single_arm import goal_distance


@pytest.fixture(scope="module")
def sampler():
    s = registry.make_sampler("reach")
    yield s
    s.close()


def test_goal_distance_over_the_last_axis():
    assert goal_distance([0.0, 0.0, 0.0], [3.0, 4.0, 0.0]) == pytest.approx(5.0)
    a = np.zeros((2, 4, 3))
    b = np.ones((2, 4, 3))
    d = goal_distance(a, b)
    assert d.shape == (2, 4)
    np.testing.assert_allclose(d, np.sqrt(3.0))


def test_default_goal_is_the_workspace_centre(sampler):
    task = sampler.make_task()
    np.testing.assert_allclose(task.goal, 0.5 * (task.ws_low + task.ws_high))


def test_goal_is_copied_and_reshaped(sampler):
    goal = np.array([[0.3], [0.1], [0.2]])
    task = sampler.make_task(goal=goal)
    goal[0, 0] = 9.0
    np.testing.assert_array_equal(task.goal, [0.3, 0.1, 0.2])
    desired = task.desired_goal()
    desired[0] = 7.0  # a copy: the task's goal stays
    assert task.goal[0] == 0.3


def test_reset_moves_the_marker_to_the_goal(sampler):
    task = sampler.sample_task(4)
    mocap = task.data.mocap_pos[task._mocap]
    np.testing.assert_allclose(mocap, task.goal)
    marker = sampler.scene.model.body(task.marker_body).id
    np.testing.assert_allclose(task.data.xpos[marker], task.goal)


def test_robot_parts_match_their_bounds(sampler):
    task = sampler.sample_task(1)
    parts = task.robot_parts()
    assert [p.name for p in parts] == ["arm_qpos", "arm_qvel", "gripper", "ee_pos"]
    assert all(p.live for p in parts)  # views of data, no copies
    bounds = {p.name: (p.low, p.high) for p in parts}
    for part in parts:
        low, high = bounds[part.name]
        assert part.read().shape == low.shape == high.shape, part.name
        assert np.all(low <= part.read()) and np.all(part.read() <= high), part.name
    np.testing.assert_array_equal(bounds["arm_qpos"][0], task.arm.joint_range[:, 0])
    np.testing.assert_array_equal(bounds["arm_qvel"][1], np.full(6, task.max_qvel))
    np.testing.assert_array_equal(bounds["ee_pos"][0], task.ws_low)
    np.testing.assert_allclose(task.get_observation()["ee_pos"], task.ee_pos())
    np.testing.assert_array_equal(task.ee_pos(), task.arm.get_frame_position(task.data))


def test_bounds_are_copies(sampler):
    task = sampler.make_task()
    task.goal_bounds()[0][:] = 99.0
    task.observation_bounds()["ee_pos"][1][:] = -99.0
    assert np.all(task.goal_bounds()[0] < 1.0)
    assert np.all(task.observation_bounds()["ee_pos"][1] > 0)


def test_assigning_the_goal_moves_the_goal_part(sampler):
    task = sampler.make_task(goal=[0.3, 0.0, 0.2])
    desired = task.goals[1]
    task.goal = [0.25, 0.05, 0.15]
    np.testing.assert_array_equal(desired.read(), [0.25, 0.05, 0.15])
    np.testing.assert_array_equal(task.desired_goal(), [0.25, 0.05, 0.15])


def test_success_and_reward_follow_the_tolerance(sampler):
    sampler.sample_task(2)
    here = sampler.make_task().ee_pos()
    tol = float(sampler.config["success_tolerance"])
    inside = sampler.make_task(goal=here + [0.5 * tol, 0.0, 0.0])
    outside = sampler.make_task(goal=here + [0.0, 0.0, 2.0 * tol])
    assert inside.judge_success() and not outside.judge_success()
    assert inside.get_info() == {"is_success": True, "goal_distance": pytest.approx(0.5 * tol)}
    assert outside.get_info()["goal_distance"] == pytest.approx(2.0 * tol)
    sparse = outside.goal_reward(np.stack([here, here + [0, 0, tol]]), inside.desired_goal())
    np.testing.assert_array_equal(sparse, [0.0, -1.0])


def test_dense_goal_reward_is_minus_the_distance():
    s = registry.make_sampler("reach", goal_reward_type="dense")
    try:
        task = s.make_task(goal=[0.3, 0.0, 0.2])
        achieved = np.array([[0.3, 0.0, 0.2], [0.3, 0.4, 0.2], [0.0, 0.0, -0.2]])
        np.testing.assert_allclose(task.goal_reward(achieved, task.goal), [0.0, -0.4, -0.5])
    finally:
        s.close()


def test_initial_joints_come_from_the_config():
    qpos = [0.1, 0.3, 0.2, -0.1, 0.05, 0.0]
    s = registry.make_sampler("reach", init_arm_qpos=qpos, init_joint_noise=0.0)
    try:
        task = s.sample_task(0)
        np.testing.assert_allclose(task.arm.get_qpos(task.data), qpos, atol=1e-12)
        np.testing.assert_allclose(task.gripper.get_noop_ctrl(task.data), [GRIPPER_OPEN])
        assert s.robot_config().init_qpos["gripper"] == [GRIPPER_OPEN, GRIPPER_OPEN]
    finally:
        s.close()


def test_joint_noise_is_seeded_and_bounded(sampler):
    base = np.asarray(sampler.config["init_arm_qpos"])
    noise = float(sampler.config["init_joint_noise"])
    starts = []
    for seed in (11, 11, 12):
        task = sampler.sample_task(seed)
        starts.append(task.arm.get_qpos(task.data))
    np.testing.assert_array_equal(starts[0], starts[1])
    assert not np.array_equal(starts[0], starts[2])
    for q in starts:
        assert np.all(np.abs(q - base) <= noise) and np.any(q != base)


def test_joint_noise_stays_within_the_joint_limits():
    probe = registry.make_sampler("reach")
    low = probe.scene.robots["wxai"].view.get_move_group("arm").joint_range[:, 0].copy()
    probe.close()
    s = registry.make_sampler("reach", init_arm_qpos=low.tolist(), init_joint_noise=0.5)
    try:
        arm = s.scene.robots["wxai"].view.get_move_group("arm")
        for seed in range(5):
            s.scene.reset()
            s.perturb_arm(np.random.default_rng(seed))
            q = arm.get_qpos(s.scene.data)
            assert np.all(q >= arm.joint_range[:, 0]) and np.all(q <= arm.joint_range[:, 1])
    finally:
        s.close()


def test_push_marker_is_its_goal_body():
    s = registry.make_sampler("push")
    try:
        task = s.sample_task(3)
        assert task.marker_body == "goal"
        np.testing.assert_allclose(task.data.mocap_pos[task._mocap], task.goal)
        # push.yaml sets init_gripper: 0.0 (closed fingers push better)
        assert s.robot_config().init_qpos["gripper"] == [0.0, 0.0]
        np.testing.assert_allclose(task.gripper.get_noop_ctrl(task.data), [0.0], atol=1e-9)
    finally:
        s.close()


def test_a_subclass_changes_the_reward_through_reward_at(sampler):
    """The wxai rewards derive from one goal distance: a subclass overriding reward_at (or
    get_reward) is what score() gives."""
    from trossen_arm_mujoco.tasks.reach import ReachTask

    class Halved(ReachTask):
        def reward_at(self, dist: float) -> float:
            return 0.5 * super().reward_at(dist)

    class Constant(ReachTask):
        def get_reward(self) -> float:
            return 7.0

    sampler.sample_task(0)
    plain = ReachTask(sampler.scene, sampler.config, goal=[0.3, 0.0, 0.2])
    halved = Halved(sampler.scene, sampler.config, goal=[0.3, 0.0, 0.2])
    assert halved.score()[0] == pytest.approx(0.5 * plain.score()[0])
    assert halved.score()[1] == plain.score()[1]
    assert Constant(sampler.scene, sampler.config).score()[0] == 7.0


def test_a_subclass_observing_more_extends_the_parts(sampler):
    """A task observing more declares more parts; dict, bounds and goals follow."""
    from trossen_arm_mujoco.tasks.observation import Part
    from trossen_arm_mujoco.tasks.reach import ReachTask

    class Clock(ReachTask):
        def observation_parts(self):
            data = self.data
            return [*super().observation_parts(), Part("time", lambda: [data.time], 0, 1e3)]

    sampler.sample_task(0)
    task = Clock(sampler.scene, sampler.config)
    obs = task.get_observation()
    assert list(obs)[-2:] == ["ee_pos", "time"] and obs["time"].shape == (1,)
    assert list(task.observation_bounds()) == list(obs)
    assert obs["time"][0] == sampler.scene.data.time
    np.testing.assert_array_equal(task.achieved_goal(), obs["ee_pos"])
