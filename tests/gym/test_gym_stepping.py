"""Stepping regimes: fast never sleeps, paused lasts policy_dt, realtime tracks wall time."""

from __future__ import annotations

import time

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.stepping import PausedStepper, make_stepper

REACH = "TrossenMujoco/WXAIReach-v0"


def test_fast_is_faster_than_real_time(make_env):
    env = make_env(REACH, stepping="fast")
    env.reset(seed=0)
    t0 = time.perf_counter()
    for _ in range(50):
        env.step(env.action_space.sample())
    assert time.perf_counter() - t0 < 0.5  # 1 s of simulated time


def test_paused_step_lasts_policy_dt(make_env):
    env = make_env(REACH, stepping="paused")
    env.reset(seed=0)
    data = env.unwrapped.scene.data
    t0, sim0 = time.perf_counter(), data.time
    for _ in range(10):
        env.step(env.action_space.sample())
    wall = time.perf_counter() - t0
    assert data.time - sim0 == pytest.approx(0.2)
    assert 0.2 <= wall < 0.4


def test_paused_sleeps_the_remainder():
    clock = iter([0.0, 0.005])
    slept = []
    stepper = PausedStepper(clock=lambda: next(clock), sleep=slept.append)

    class FakeTask:
        policy_dt = 0.02
        n_ctrl_steps = 1

        class scene:  # noqa: N801
            @staticmethod
            def step(n):
                pass

        def advance(self, commands):
            self.scene.step(self.n_ctrl_steps)

    stepper.step(FakeTask(), {})
    assert slept == [pytest.approx(0.015)]


def test_realtime_tracks_wall_clock(make_env):
    env = make_env(REACH, stepping="realtime", action_mode="ee_delta")
    env.reset(seed=0)
    data = env.unwrapped.scene.data
    rng = np.random.default_rng(0)
    step_times = []
    t0, sim0 = time.perf_counter(), data.time
    while time.perf_counter() - t0 < 2.0:
        s = time.perf_counter()
        obs, *_ = env.step(rng.uniform(-1, 1, 4))
        step_times.append(time.perf_counter() - s)
        time.sleep(0.01)  # the policy thinks; physics keeps running
    wall = time.perf_counter() - t0
    sim = data.time - sim0
    assert abs(sim - wall) <= 0.1 * wall, (sim, wall)
    assert np.median(step_times) < 0.01  # returns at once, no waiting for physics
    assert env.unwrapped.task.n_steps == len(step_times)
    assert env.observation_space.contains(obs)


def test_realtime_physics_runs_between_steps(make_env):
    env = make_env(REACH, stepping="realtime")
    env.reset(seed=0)
    data = env.unwrapped.scene.data
    sim0 = data.time
    time.sleep(0.2)
    assert data.time - sim0 > 0.1
    env.reset(seed=0)  # restarts cleanly
    env.step(env.action_space.sample())


def test_unknown_stepping_lists_modes(make_env):
    with pytest.raises(UserError, match="fast, paused, realtime"):
        make_env(REACH, stepping="turbo")
    with pytest.raises(UserError, match="fast"):
        make_stepper("slow")


@pytest.mark.parametrize("stepping", ["fast", "paused"])
def test_regimes_advance_time_through_the_env_step_loop(make_env, stepping):
    """One gym step = Task.advance = policy_dt / ctrl_dt ticks of Scene.step."""
    env = make_env(REACH, stepping=stepping, ctrl_dt=0.01)
    env.reset(seed=0)
    scene = env.unwrapped.scene
    calls = []
    original = scene.step
    scene.step = lambda n=1: (calls.append(n), original(n))
    t0 = scene.data.time
    env.step(env.action_space.sample())
    assert calls == [2]  # policy_dt 0.02 s / ctrl_dt 0.01 s, from the task's config
    assert scene.data.time - t0 == pytest.approx(env.unwrapped.task.policy_dt)


def test_realtime_ticks_through_env_step_and_keeps_moving_toward_the_action(make_env):
    """The background thread runs env.step(1) per tick: a far joint target is approached
    at the rate limit tick after tick, not just once when the action arrives."""
    env = make_env(REACH, stepping="realtime")
    env.reset(seed=0)
    u = env.unwrapped
    scene, arm = u.scene, u.task.arm
    calls = []
    original = scene.step
    scene.step = lambda n=1: (calls.append(n), original(n))
    with u.stepper.lock:
        c0 = arm.get_ctrl(scene.data)
    action = np.ones(env.action_space.shape, dtype=np.float32)  # every joint to its upper end
    env.step(action)
    time.sleep(0.3)
    with u.stepper.lock:
        moved = np.abs(arm.get_ctrl(scene.data) - c0)
    max_step = arm.velocity_limits * u.task.ctrl_dt
    assert calls and set(calls) == {1}
    assert np.max(moved / max_step) > 3  # several ticks' worth, at the limit
