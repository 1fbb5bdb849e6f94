"""Task base: timing (sim_dt, ctrl_dt, policy_dt), episodic API, errors."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry


@pytest.fixture
def reach():
    sampler = registry.make_sampler("reach")
    yield sampler
    sampler.close()


def test_timing_defaults(reach):
    task = reach.sample_task(0)
    assert task.sim_dt == pytest.approx(0.002)
    assert task.ctrl_dt == pytest.approx(0.02)
    assert task.policy_dt == pytest.approx(0.02)
    assert task.n_ctrl_steps == 1 and reach.scene.n_substeps == 10


def test_one_step_lasts_policy_dt():
    sampler = registry.make_sampler("reach", ctrl_dt=0.004, policy_dt=0.04)
    try:
        task = sampler.sample_task(0)
        assert (task.n_ctrl_steps, sampler.scene.n_substeps) == (10, 2)
        t0 = sampler.scene.data.time
        task.step({})
        task.step({})
        assert sampler.scene.data.time - t0 == pytest.approx(0.08)
        assert task.n_steps == 2
    finally:
        sampler.close()


def test_policy_dt_not_a_multiple_of_ctrl_dt():
    with pytest.raises(
        UserError, match=r"policy_dt \(0.03 s\) must be a whole multiple of ctrl_dt"
    ):
        registry.make_sampler("reach", policy_dt=0.03)


def test_ctrl_dt_not_a_multiple_of_sim_dt():
    with pytest.raises(UserError, match="ctrl_dt .* whole multiple of sim_dt"):
        registry.make_sampler("push", ctrl_dt=0.003, policy_dt=0.03)


def test_policy_dt_shorter_than_ctrl_dt():
    with pytest.raises(UserError, match="policy_dt"):
        registry.make_sampler("reach", policy_dt=0.01)


def test_done_after_max_episode_steps():
    sampler = registry.make_sampler("reach", max_episode_steps=3)
    try:
        task = sampler.sample_task(0)
        dones, timed_out = [], []
        for _ in range(3):
            dones.append(task.step({})[2])
            timed_out.append(task.is_timed_out())
        assert dones == timed_out == [False, False, True]
        assert task.is_done() and not task.is_terminal()
    finally:
        sampler.close()


def test_never_timed_out_without_max_episode_steps(reach):
    task = reach.sample_task(0)
    task.max_episode_steps = None
    for _ in range(3):
        task.step({})
    assert not task.is_timed_out() and not task.is_done()


def test_terminate_on_success(reach):
    task = reach.sample_task(0)
    assert not task.is_terminal()
    task.config["terminate_on_success"] = True
    task.goal = task.ee_pos()
    assert task.judge_success() and task.is_terminal() and task.is_done()


def test_step_takes_commands_dict(reach):
    task = reach.sample_task(0)
    q = task.arm.get_qpos(task.data)
    obs, reward, done = task.step({"arm": q, "gripper": np.array([0.02])})
    assert set(obs) == {"arm_qpos", "arm_qvel", "gripper", "ee_pos"}
    assert np.isfinite(reward) and not done
    with pytest.raises(UserError, match="dict"):
        task.step(np.zeros(7))
    with pytest.raises(UserError, match="move group"):
        task.step({"left_arm": q})


def test_reset_restarts_counters(reach):
    task = reach.sample_task(0)
    task.step({})
    task.reset()
    assert task.n_steps == 0


@pytest.mark.parametrize("name", registry.names())
def test_description_and_info(name):
    sampler = registry.make_sampler(name)
    try:
        task = sampler.sample_task(1)
        assert isinstance(task.get_task_description(), str) and task.get_task_description()
        info = task.get_info()
        assert info["is_success"] is False
        bounds = task.observation_bounds()
        obs = task.get_observation()
        assert list(bounds) == list(obs)
        for key, value in obs.items():
            low, high = bounds[key]
            assert value.shape == low.shape == high.shape, key
            assert np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low < high)
    finally:
        sampler.close()


def test_score_is_reward_and_info(reach):
    task = reach.sample_task(0)
    reward, info = task.score()
    assert (reward, info) == (task.get_reward(), task.get_info())
    assert task.current_reward() == reward  # outside score(): get_reward() again


def test_a_success_defined_by_the_reward_evaluates_it_once_per_score(monkeypatch):
    """The bimanual tasks' success is ``reward >= max_reward``: inside score() it reuses
    the reward score() has just computed (current_reward), so the contacts are read once."""
    from trossen_arm_mujoco.tasks.transfer_cube import TransferCube

    sampler = registry.make_sampler("transfer_cube")
    try:
        task = sampler.sample_task(0)
        calls = []
        real = TransferCube.get_reward
        monkeypatch.setattr(TransferCube, "get_reward", lambda t: calls.append(1) or real(t))
        assert task.score() == (0.0, {"is_success": False})
        assert len(calls) == 1
        assert task.judge_success() is False and len(calls) == 2  # outside: evaluated
        assert task._reward_now is None
    finally:
        sampler.close()


def test_score_goes_through_overridden_reward_and_info():
    """A subclass overriding get_reward or get_info is scored through its own methods."""
    from trossen_arm_mujoco.tasks.reach import ReachTask
    from trossen_arm_mujoco.tasks.transfer_cube import TransferCube

    class Constant(ReachTask):
        def get_reward(self) -> float:
            return 7.0

    class Tagged(TransferCube):
        def get_info(self):
            return {**super().get_info(), "tag": 1}

    class Rewarded(TransferCube):  # get_reward below the shared score: still used
        def get_reward(self) -> int:
            return 4

    for name, cls, expected in [
        ("reach", Constant, lambda r, i: r == 7.0 and "goal_distance" in i),
        ("transfer_cube", Tagged, lambda r, i: i["tag"] == 1),
        ("transfer_cube", Rewarded, lambda r, i: r == 4.0 and i == {"is_success": True}),
    ]:
        sampler = registry.make_sampler(name)
        try:
            sampler.sample_task(0)
            task = cls(sampler.scene, sampler.config)
            task.reset()
            assert expected(*task.score())
        finally:
            sampler.close()
