"""``twin.replay_clock``: when a served leader pair's replay runs (a fake clock: no
waiting, nothing served)."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.twin.replay_clock import ReplayClock


def test_replay_clock_waits_for_both_arms_then_the_lead_in():
    now = [100.0]
    clock = ReplayClock(duration=2.0, speed=2.0, lead_in=0.5, now=lambda: now[0])
    clock.client_ready("left")
    now[0] += 10.0
    assert clock.replay_time() == 0.0 and not clock.triggered.is_set()  # right missing
    clock.client_ready("right")
    assert clock.triggered.is_set() and clock.start_time == pytest.approx(110.5)
    now[0] += 0.25
    assert clock.replay_time() == 0.0 and not clock.started.is_set()  # lead-in
    now[0] += 0.75  # 0.5 s after the lead-in, at speed 2
    assert clock.replay_time() == pytest.approx(1.0) and clock.started.is_set()
    now[0] += 5.0
    assert clock.replay_time() == 2.0 and clock.finished.is_set()  # held at the end


def test_clock_phases_with_an_approach():
    now = [10.0]
    clock = ReplayClock(
        duration=2.0, speed=2.0, lead_in=0.5, now=lambda: now[0], approach=lambda: 1.0
    )
    assert clock.phase() == ("rest", 0.0)
    clock.trigger()
    assert clock.approach_s == 1.0 and clock.phase() == ("rest", 0.0)  # lead-in
    now[0] += 0.75
    assert clock.phase() == ("approach", pytest.approx(0.25)) and clock.started.is_set()
    assert clock.replay_time() == 0.0
    now[0] += 1.0  # 0.25 s of play at speed 2
    assert clock.phase() == ("play", pytest.approx(0.5))
    now[0] += 5.0
    assert clock.phase() == ("play", 2.0) and clock.finished.is_set()
