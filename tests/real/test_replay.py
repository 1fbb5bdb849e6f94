"""The replay loop on the simulated twin: streaming, timing, and the safe exit on stop."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.clock import SimClock
from trossen_arm_mujoco.real.driver import HOME_POSE, SLEEP_POSE
from trossen_arm_mujoco.real.gripper import clamp_gripper
from trossen_arm_mujoco.real.replay import (
    MAX_COMMAND_PERIOD,
    MAX_FPS,
    MIN_FPS,
    WAIT_SLICE,
    ReplayConfig,
    check_fps,
    make_drivers,
    replay,
    wait,
)
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.real.validate import validate_actions
from trossen_arm_mujoco.stopping import STOP_SIGNALS, StopSignals


class SignalClock(SimClock):
    """Sends ``signum`` to this process once simulated time reaches ``at`` seconds."""

    def __init__(self, at: float, signum: int) -> None:
        super().__init__()
        self.at, self.signum, self.sent_at = at, signum, None

    def sleep(self, seconds: float) -> None:
        super().sleep(seconds)
        if self.sent_at is None and self.now() >= self.at:
            self.sent_at = self.now()
            os.kill(os.getpid(), self.signum)


class RaisingClock(SimClock):
    """Raises KeyboardInterrupt from inside a wait once time reaches ``at`` seconds."""

    def __init__(self, at: float) -> None:
        super().__init__()
        self.at, self.raised = at, False

    def sleep(self, seconds: float) -> None:
        super().sleep(seconds)
        if not self.raised and self.now() >= self.at:
            self.raised = True
            raise KeyboardInterrupt


class FailingArm(SimArmDriver):
    """A twin whose ``set_all_positions`` fails on call number ``fail_on`` (1-based)."""

    def __init__(self, clock: SimClock, fail_on: int) -> None:
        super().__init__(clock)
        self.calls, self.fail_on = 0, fail_on

    def set_all_positions(self, positions, goal_time, blocking) -> None:
        self.calls += 1
        if self.calls == self.fail_on:
            raise RuntimeError("joint_3 driver overheated\n(error state 10)")
        super().set_all_positions(positions, goal_time, blocking)


def assert_asleep(result, drivers) -> None:
    for side in ("left", "right"):
        np.testing.assert_allclose(result.final_positions[side][:6], SLEEP_POSE[:6], atol=0.01)
        np.testing.assert_allclose(drivers[side].get_all_positions()[:6], 0.0, atol=0.01)
        assert not drivers[side].configured  # cleaned up


def test_full_replay_tracks_and_ends_asleep(smooth) -> None:
    traj = validate_actions(smooth(20), 10.0)
    drivers, clock = make_drivers("sim")
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert result.status == "completed" and result.exit_code == 0 and result.reason is None
    assert result.steps_done == 20 and result.late_steps == 0
    times, cmd, meas = result.log.arrays()
    np.testing.assert_allclose(np.diff(times), 0.1, atol=1e-9)  # one period per step
    sent, clamp = clamp_gripper(traj.commands, 0.04)  # the commands as sent: gripper <= 0.04
    np.testing.assert_array_equal(cmd.reshape(20, 2, 7), sent)
    assert result.gripper == clamp and clamp.count == np.count_nonzero(traj.commands[..., 6] > 0.04)
    assert 0 < clamp.count < 40 and clamp.per_arm["left"] == clamp.per_arm["right"]
    err = result.log.errors()
    assert all(np.isfinite(e["rms"]) for e in err.values())
    assert err["left_joint_1"]["max"] < 0.1 and err["right_gripper"]["max"] < 0.005
    assert drivers["left"].ip_address == "192.168.1.5"  # recorded only; the twin has no network
    # start 2 s + settle, 2 s of streaming, home and sleep 2 s + settle each
    assert clock.now() == pytest.approx(2.5 + 2.0 + 2.5 + 2.5, abs=0.01)
    assert_asleep(result, drivers)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_mid_stream_goes_home_then_sleeps(signum: int, smooth) -> None:
    previous = signal.getsignal(signum)
    traj = validate_actions(smooth(40), 10.0)
    clock = SignalClock(at=2.5 + 1.0, signum=signum)  # 1 s into streaming
    drivers, clock = make_drivers("sim", clock)
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert clock.sent_at is not None
    assert result.status == "interrupted" and result.exit_code == 128 + signum
    assert 5 <= result.steps_done < 40
    assert f"interrupted by {signal.Signals(signum).name}" in result.reason
    assert "\n" not in result.reason
    assert_asleep(result, drivers)
    assert signal.getsignal(signum) is previous  # handler restored


def test_keyboard_interrupt_inside_a_wait_still_goes_to_sleep(smooth) -> None:
    traj = validate_actions(smooth(40), 10.0)
    drivers, clock = make_drivers("sim", RaisingClock(at=3.0))
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert result.exit_code == 130 and "KeyboardInterrupt" in result.reason
    assert_asleep(result, drivers)


def test_driver_error_mid_stream_stops_and_sleeps(smooth) -> None:
    traj = validate_actions(smooth(40), 10.0)
    clock = SimClock()
    drivers = {"left": SimArmDriver(clock), "right": FailingArm(clock, fail_on=11)}
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert result.status == "failed" and result.exit_code == 1
    assert result.steps_done == 9  # call 1 = start pose, calls 2..10 = steps 0..8
    assert result.reason == (
        "replay stopped at step 9/40: right arm: set_all_positions (step 9) failed: "
        "joint_3 driver overheated (error state 10)"
    )
    assert_asleep(result, drivers)


def test_errors_while_shutting_down_are_reported_and_other_arm_still_sleeps(smooth) -> None:
    traj = validate_actions(smooth(10), 10.0)
    clock = SimClock()
    # call 1 start, 2..11 streaming, 12 home fails, 13 (its retry) and 14 (sleep) succeed
    drivers = {"left": FailingArm(clock, fail_on=12), "right": SimArmDriver(clock)}
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert result.exit_code == 1 and result.steps_done == 10
    assert result.reason == (
        "replay streamed 10/10 steps; shutdown errors: left arm: set_all_positions (home) "
        "failed: joint_3 driver overheated (error state 10) (the retry succeeded)"
    )
    assert_asleep(result, drivers)


def test_configure_failure_moves_nothing_and_cleans_up(smooth) -> None:
    class Unreachable(SimArmDriver):
        def configure(self, ip_address, *args, **kwargs):
            raise RuntimeError(f"cannot connect to {ip_address}")

    clock = SimClock()
    drivers = {"left": SimArmDriver(clock), "right": Unreachable(clock)}
    traj = validate_actions(smooth(10), 10.0)
    result = replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    assert result.exit_code == 1 and result.steps_done == 0
    assert "right arm: configure (192.168.1.4) failed: cannot connect" in result.reason
    assert "right" not in result.final_positions  # never configured, never commanded
    np.testing.assert_allclose(result.final_positions["left"][:6], 0.0, atol=0.01)


def test_sim_replay_runs_much_faster_than_real_time(smooth) -> None:
    traj = validate_actions(smooth(100), 10.0)
    drivers, clock = make_drivers("sim")
    t0 = time.perf_counter()
    replay(traj, drivers, clock, ReplayConfig(fps=10.0, progress=False))
    wall = time.perf_counter() - t0
    assert clock.now() > 17.0 and wall < clock.now() / 5


def test_stop_signals_restore_handlers_and_keep_the_first_reason() -> None:
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    stops = StopSignals()
    with stops.handling():
        assert signal.getsignal(signal.SIGINT) is not before[0]
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    assert stops.reason == "SIGTERM" and stops.exit_code == 143 and stops.by_signal


@pytest.fixture
def leak_guard():
    """SIGTERM/SIGHUP/SIGQUIT raise here while a test runs, instead of ending pytest."""

    def leaked(signum, _frame):
        raise RuntimeError(f"signal leaked: {signal.Signals(signum).name}")

    previous = {s: signal.signal(s, leaked) for s in STOP_SIGNALS if s != signal.SIGINT}
    yield leaked
    for s, old in previous.items():
        signal.signal(s, old)


@pytest.mark.parametrize("fps", [0.5, 1.0, 10.0, 1000.0])
def test_check_fps_accepts_command_periods_from_1_ms_to_2_s(fps: float) -> None:
    check_fps(fps)


@pytest.mark.parametrize(
    ("fps", "expected"),
    [
        (1e-9, "got 1e-09: one command would last 1e+09 s; one command lasts 1/fps"),
        (0.4999, "got 0.4999: one command would last 2 s;"),
        (0.0, "got 0: one command lasts 1/fps, which must be between 1 ms and 2 s"),
        (-5.0, "got -5: one command lasts 1/fps"),
        (float("nan"), "got nan:"),
        (float("inf"), "got inf:"),
        (1000.5, "got 1000.5:"),
    ],
)
def test_check_fps_rejects_with_the_bounds_and_the_reason(fps: float, expected: str) -> None:
    with pytest.raises(UserError) as exc:
        check_fps(fps)
    text = str(exc.value)
    assert text.startswith("--fps must be in [0.5, 1000] Hz, ") and expected in text
    assert "trossen_arm gives a whole move by default" in text and "\n" not in text
    assert MIN_FPS == 1 / MAX_COMMAND_PERIOD == 0.5 and MAX_FPS == 1000


class StampedArm(SimArmDriver):
    """The twin, recording the clock time of every goal it is sent."""

    def __init__(self, clock: SimClock) -> None:
        super().__init__(clock)
        self.stamps: list[tuple[float, np.ndarray]] = []

    def set_all_positions(self, positions, goal_time, blocking) -> None:
        self.stamps.append((self.clock.now(), np.asarray(positions, dtype=float).copy()))
        super().set_all_positions(positions, goal_time, blocking)


@pytest.mark.parametrize("signum", STOP_SIGNALS)
def test_a_signal_mid_period_stops_within_one_wait_slice(signum: int, smooth, leak_guard) -> None:
    """At 0.5 fps each command lasts 2 s; a signal 0.3 s into a period is acted on within
    one wait slice, not at the period's end; the step is not logged (its measurement
    would come early)."""
    previous = signal.getsignal(signum)
    fps, at = 0.5, 2.5 + 2.0 + 0.3  # start + settle, one period, then 0.3 s into step 1
    clock = SignalClock(at=at, signum=signum)
    drivers = {side: StampedArm(clock) for side in ("left", "right")}
    traj = validate_actions(smooth(5, fps=fps), fps)
    result = replay(traj, drivers, clock, ReplayConfig(fps=fps, progress=False))
    assert result.status == "interrupted" and result.exit_code == 128 + signum
    assert result.steps_done == 1 and result.late_signals == []
    home_sent = next(t for t, goal in drivers["left"].stamps if np.allclose(goal, HOME_POSE))
    assert clock.sent_at <= home_sent <= clock.sent_at + WAIT_SLICE + 1e-9
    assert_asleep(result, drivers)
    assert signal.getsignal(signum) is previous


def test_a_signal_while_the_arms_go_home_is_only_noted(smooth, leak_guard) -> None:
    clock = SignalClock(at=2.5 + 1.0 + 0.5, signum=signal.SIGTERM)  # streaming ends at 3.5 s
    drivers, clock = make_drivers("sim", clock)
    result = replay(
        validate_actions(smooth(10), 10.0), drivers, clock, ReplayConfig(progress=False)
    )
    assert clock.sent_at is not None
    assert result.status == "completed" and result.exit_code == 0 and result.reason is None
    assert result.late_signals == ["SIGTERM"] and result.steps_done == 10
    assert_asleep(result, drivers)


def test_waits_are_sliced_and_end_once_a_stop_is_requested() -> None:
    class Counting(SimClock):
        def __init__(self) -> None:
            super().__init__()
            self.slices: list[float] = []

        def sleep(self, seconds: float) -> None:
            self.slices.append(seconds)
            super().sleep(seconds)

    clock, stops = Counting(), StopSignals()
    wait(clock, 1.0, stops)
    assert clock.now() == pytest.approx(1.0) and max(clock.slices) <= WAIT_SLICE
    stops.request("stop", 1)
    wait(clock, 1e9, stops)  # returns at once
    assert clock.now() == pytest.approx(1.0)
