"""The served kit in this process, driven by the installed ``trossen_arm`` driver over loopback
(127.0.0.41 / 127.0.0.42 in this module)."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

pytest.importorskip("trossen_arm_sim")
ta = pytest.importorskip("trossen_arm")

from trossen_arm_mujoco.errors import UserError  # noqa: E402
from trossen_arm_mujoco.twin.serving import check_loopback  # noqa: E402

LEFT, RIGHT = "127.0.0.41", "127.0.0.42"
GOAL_L = [0.3, 0.6, 0.5, 0.2, -0.2, 0.3, 0.03]
GOAL_R = [-0.3, 0.5, 0.6, -0.2, 0.2, -0.3, 0.01]


def settle(driver, goal, atol_rad: float = 0.02, atol_m: float = 0.002, timeout: float = 3.0):
    """Measured positions once within tolerance of ``goal`` (or at the timeout)."""
    end = time.monotonic() + timeout
    while True:
        pos = np.asarray(driver.get_all_positions())
        err = np.abs(pos - goal)
        if (err[:6].max() <= atol_rad and err[6] <= atol_m) or time.monotonic() > end:
            return pos
        time.sleep(0.05)


def test_both_arms_follow_position_moves(served_kit, arm_driver) -> None:
    lines: list[str] = []
    kit = served_kit(LEFT, RIGHT, say=lines.append)
    t0 = time.monotonic()
    left, right = arm_driver(LEFT), arm_driver(RIGHT)
    connect_s = time.monotonic() - t0
    assert connect_s < 5.0
    assert kit.connected == ["left", "right"]
    start = np.asarray(left.get_all_positions())
    np.testing.assert_allclose(start[:3], [0.0, np.pi / 12, np.pi / 12], atol=0.01)
    limits = left.get_joint_limits()
    assert limits[0].velocity_max == pytest.approx(3.375)
    assert limits[6].position_max == pytest.approx(0.044)
    left.set_all_positions(GOAL_L, 1.0, False)
    right.set_all_positions(GOAL_R, 1.0, True)
    for driver, goal in ((left, GOAL_L), (right, GOAL_R)):
        pos = settle(driver, np.array(goal))
        np.testing.assert_allclose(pos[:6], goal[:6], atol=0.02)
        assert abs(pos[6] - goal[6]) <= 0.002
    # the world saw both: its recorded action holds the commanded targets
    action = kit.world.action()
    np.testing.assert_allclose(action[0:6], GOAL_L[:6], atol=1e-6)
    np.testing.assert_allclose(action[8:14], GOAL_R[:6], atol=1e-6)
    left.cleanup()
    right.cleanup()
    end = time.monotonic() + 2.0
    while kit.connected and time.monotonic() < end:  # the servers see the clients leave
        time.sleep(0.05)
    assert kit.connected == []
    assert lines[:2] == [
        f"left arm ({LEFT}): client connected",
        f"right arm ({RIGHT}): client connected",
    ]
    assert kit.world.realtime_factor > 0.2  # paced; far below 1 only on a starved machine


def test_limit_violation_faults_and_clear_error_recovers(served_kit, arm_driver) -> None:
    kit = served_kit(LEFT, RIGHT)
    driver = arm_driver(LEFT)
    limits = driver.get_joint_limits()
    limits[0].position_max = 0.2  # set_joint_limits: the served arm checks against these
    driver.set_joint_limits(limits)
    assert driver.get_joint_limits()[0].position_max == pytest.approx(0.2)
    here = list(driver.get_all_positions())
    driver.set_all_positions([0.5, *here[1:]], 1.0, True)  # passes 0.21 rad on the way
    with pytest.raises(RuntimeError, match="Joint limit exceeded"):
        driver.set_all_positions(here, 1.0, True)
    assert kit.servers["left"].error_state == 15  # JOINT_LIMIT_EXCEEDED
    assert "joint_0: position command" in kit.faults[0]
    with kit.world.lock:  # the driver raises on every call now; ask the world
        held = kit.world.measured("left")
    assert held[0] < 0.25  # the arm stopped at the fault, its joints idle (held)
    driver.clear_error()  # cleanup + configure(clear_error=True), as the driver documents
    assert kit.servers["left"].error_state == 0
    driver.set_all_modes(ta.Mode.position)
    back = [0.0, *here[1:]]
    driver.set_all_positions(back, 1.0, True)
    np.testing.assert_allclose(settle(driver, np.array(back))[:6], back[:6], atol=0.02)


def test_non_finite_input_is_robot_input_infinite(served_kit, arm_driver) -> None:
    kit = served_kit(LEFT, RIGHT)
    driver = arm_driver(RIGHT)
    here = list(driver.get_all_positions())
    try:
        driver.set_all_positions([math.nan, *here[1:]], 0.0, False)
        time.sleep(0.2)
        driver.get_all_positions()
        driver.set_all_positions(here, 0.5, True)
    except RuntimeError as exc:
        assert "infinite" in str(exc)
    else:
        pytest.fail("a NaN command did not fault the arm")
    assert kit.servers["right"].error_state == 16  # ROBOT_INPUT_INFINITE


def test_velocity_and_external_effort_modes(served_kit, arm_driver) -> None:
    served_kit(LEFT, RIGHT)
    driver = arm_driver(LEFT, position_mode=False)
    start = np.asarray(driver.get_all_positions())
    driver.set_all_modes(ta.Mode.velocity)
    driver.set_all_velocities([0.4, 0, 0, 0, 0, 0, 0], 0.0, False)
    time.sleep(0.5)
    driver.set_all_velocities([0.0] * 7, 0.0, False)
    time.sleep(0.3)
    moved = np.asarray(driver.get_all_positions())[0] - start[0]
    assert 0.08 < moved < 0.4  # about 0.2 rad in 0.5 s, paced by the real-time world
    driver.set_all_modes(ta.Mode.external_effort)
    driver.set_all_external_efforts([0.0] * 7, 0.0, False)
    before = np.asarray(driver.get_all_positions())
    time.sleep(0.5)
    after = np.asarray(driver.get_all_positions())
    np.testing.assert_allclose(after[:6], before[:6], atol=0.02)  # limp, gravity compensated
    assert driver.get_all_efforts()[1] != 0.0  # the shoulder carries the arm's weight


def test_stop_ends_every_thread_and_addresses_are_checked(served_kit, arm_driver) -> None:
    kit = served_kit(LEFT, RIGHT)
    arm_driver(LEFT)  # a client stays connected through stop()
    with pytest.raises(UserError, match="cannot serve the left arm on 127.0.0.41"):
        served_kit(LEFT, "127.0.0.43")
    kit.close()
    assert kit.alive_threads == 0
    names = [t.name for t in threading.enumerate()]
    assert not [n for n in names if n.startswith(("left arm", "right arm", "kit-world"))]
    for bad in ("192.168.1.5", "0.0.0.0", "localhost", "::1", "127.0.0"):
        with pytest.raises(UserError, match="not an IPv4 loopback address"):
            check_loopback(bad, "--left_ip")
    with pytest.raises(UserError, match="both 127.0.0.41"):
        served_kit(LEFT, LEFT)


def test_an_arm_out_of_file_descriptors_refuses_and_then_serves(
    served_kit, arm_driver, monkeypatch, caplog
) -> None:
    """The left arm's accept fails with EMFILE twice, and so does the accept that would take
    the waiting connection off the queue each time (as when the process has no descriptor
    left): one log line, and the listener accepts the driver afterwards (before, its thread
    ended and the arm stayed unreachable)."""
    import errno
    import logging
    import socket

    real_accept = socket.socket.accept
    failures = []

    def accept(sock):
        if sock.getsockname() == (LEFT, 50001) and len(failures) < 4:
            failures.append(1)
            raise OSError(errno.EMFILE, "Too many open files")
        return real_accept(sock)

    monkeypatch.setattr(socket.socket, "accept", accept)
    with caplog.at_level(logging.WARNING, logger="trossen_arm_mujoco.twin"):
        served_kit(LEFT, RIGHT)
        driver = arm_driver(LEFT)
    assert len(failures) == 4
    np.testing.assert_allclose(driver.get_all_positions()[1], np.pi / 12, atol=0.01)
    assert [r.getMessage() for r in caplog.records if "accept" in r.getMessage()] == [
        "left arm: cannot accept a connection (Too many open files (EMFILE)): refused it; "
        "still serving"
    ]
