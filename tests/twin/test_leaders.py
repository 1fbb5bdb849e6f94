"""Served leader arms: an episode played back over the arm controller's protocol, read by the
unmodified ``trossen_arm`` driver. Loopback addresses 127.0.0.31 .. 127.0.0.39
(the allocation is in ``tests/twin/conftest.py``)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE
from trossen_arm_mujoco.twin.leader_server import LeaderArmServer
from trossen_arm_mujoco.twin.leader_trajectory import load_leader_trajectory
from trossen_arm_mujoco.twin.leaders import (
    LeaderPair,
    serve_leaders,
)
from trossen_arm_mujoco.twin.serving import check_loopback

ta = pytest.importorskip("trossen_arm")
pytest.importorskip("trossen_arm_sim")

LEFT, RIGHT = "127.0.0.31", "127.0.0.32"
STEPS = 26  # 0.5 s at 50 Hz


def make_episode(path: Path, steps: int = STEPS) -> np.ndarray:
    """A small episode whose actions sweep left joint_0 and right joint_1 and open the
    left gripper; returns the actions (T, 16)."""
    ramp = np.linspace(0.0, 1.0, steps)
    actions = np.tile(np.asarray(START_ARM_POSE), (steps, 1))
    actions[:, 0] = 0.5 * ramp  # left joint_0 0 -> 0.5 rad
    actions[:, 9] = np.pi / 12 + 0.4 * ramp  # right joint_1
    actions[:, 6] = actions[:, 7] = 0.01 + 0.02 * ramp  # left gripper 0.01 -> 0.03 m
    qpos = actions - 0.01  # a follower a little behind
    with EpisodeWriter(
        path, episode_len=steps, attrs={"task_name": "t", "seed": 0, "success": True}
    ) as writer:
        for t in range(steps):
            writer.append(qpos[t], np.zeros(16), actions[t], 0.0, np.zeros(7))
    return actions.astype(np.float32).astype(float)


@pytest.fixture
def episode(tmp_path) -> tuple[Path, np.ndarray]:
    path = tmp_path / "episode_0.hdf5"
    return path, make_episode(path)


def connect(ip: str):
    driver = ta.TrossenArmDriver()
    driver.configure(ta.Model.wxai_v0, ta.StandardEndEffector.wxai_v0_leader, ip, True, 5.0)
    return driver


def test_trajectory_is_the_kit_layout_per_arm(episode):
    path, actions = episode
    traj = load_leader_trajectory(path)
    assert traj.positions.shape == (STEPS, 2, 7) and traj.dt == pytest.approx(0.02)
    kit = KIT14_LAYOUT.from_vendor(actions)
    np.testing.assert_allclose(traj.positions[:, 0], kit[:, 0:7])
    np.testing.assert_allclose(traj.positions[:, 1], kit[:, 7:14])
    qpos = load_leader_trajectory(path, source="qpos")
    np.testing.assert_allclose(qpos.positions[:, 0, 0], np.clip(actions[:, 0] - 0.01, -3, 3))
    # linear between steps, velocity the slope; held (zero velocity) outside the episode
    pos, vel = traj.sample(0, 0.5 * traj.dt)
    np.testing.assert_allclose(pos, 0.5 * (kit[0, 0:7] + kit[1, 0:7]))
    np.testing.assert_allclose(vel[0], (kit[1, 0] - kit[0, 0]) / traj.dt)
    for seconds, row in ((-1.0, 0), (traj.duration + 1.0, -1)):
        pos, vel = traj.sample(1, seconds)
        np.testing.assert_allclose(pos, kit[row, 7:14])
        assert not vel.any()
    with pytest.raises(UserError, match="unknown replay source 'ctrl'"):
        load_leader_trajectory(path, source="ctrl")


def test_served_pair_plays_through_the_unmodified_driver(episode):
    path, actions = episode
    kit = KIT14_LAYOUT.from_vendor(actions)
    stop, pairs, lines = threading.Event(), [], []
    thread = threading.Thread(
        target=serve_leaders,
        args=(str(path), LEFT, RIGHT, stop),
        kwargs={"lead_in": 0.2, "say": lines.append, "on_ready": pairs.append},
    )
    thread.start()
    drivers = []
    try:
        deadline = time.monotonic() + 10
        while not pairs and thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.01)
        pair = pairs[0]
        drivers = [connect(LEFT), connect(RIGHT)]
        left, right = drivers
        np.testing.assert_allclose(left.get_all_positions(), kit[0, 0:7], atol=1e-6)
        np.testing.assert_allclose(right.get_all_positions(), kit[0, 7:14], atol=1e-6)
        # position commands do not start the replay (before it, they stage the arm: here at
        # the episode's first pose, so there is no approach; see test_leader_staging.py)
        left.set_all_modes(ta.Mode.position)
        left.set_all_positions(kit[0, 0:7].tolist(), 0.1, True)
        time.sleep(0.2)
        np.testing.assert_allclose(left.get_all_positions(), kit[0, 0:7], atol=1e-5)
        assert not pair.clock.triggered.is_set()
        # one arm in external_effort mode is not enough; both start the replay
        left.set_all_modes(ta.Mode.external_effort)
        left.set_all_external_efforts([0.0] * 7, 0.0, False)
        time.sleep(0.1)
        assert not pair.clock.triggered.is_set()
        right.set_all_modes(ta.Mode.external_effort)
        right.set_all_external_efforts([0.0] * 7, 0.0, False)
        assert pair.clock.triggered.wait(2.0)
        seen = []
        while not pair.finished.is_set() and time.monotonic() < deadline:
            seen.append(left.get_all_positions()[0])
            time.sleep(0.01)
        assert pair.finished.is_set()
        time.sleep(0.1)  # the driver reads the output of its last cycle
        np.testing.assert_allclose(left.get_all_positions(), kit[-1, 0:7], atol=1e-6)
        np.testing.assert_allclose(right.get_all_positions(), kit[-1, 7:14], atol=1e-6)
        # it moved through the episode (monotonic sweep of joint_0), and holds at the end
        assert len(seen) > 10 and np.all(np.diff(seen) >= -1e-6) and 0.0 < np.median(seen) < 0.5
        time.sleep(0.1)
        np.testing.assert_allclose(left.get_all_positions()[0], 0.5, atol=1e-6)
        velocities = left.get_all_velocities()
        assert np.allclose(velocities, 0.0)
    finally:
        for driver in drivers:
            driver.cleanup()
        stop.set()
        thread.join(10)
    assert not thread.is_alive()
    assert lines[0].startswith(f"serving leader arms replaying {path} (26 steps, 0.5 s")
    assert lines[1:] == ["leader replay started", "leader replay finished; holding the last pose"]


def test_stop_ends_every_thread_and_frees_the_addresses(episode):
    path, _ = episode
    traj = load_leader_trajectory(path)
    before = set(threading.enumerate())
    pair = LeaderPair(traj, LEFT, RIGHT)
    with pair:
        driver = connect(LEFT)  # a connected client: its TCP thread is blocked in recv
        driver.get_all_positions()
    assert all(server.alive_threads == 0 for server in pair.servers.values())
    try:
        driver.cleanup()
    except Exception:
        pass
    with LeaderPair(traj, LEFT, RIGHT) as again:  # the same addresses, at once
        again.trigger()
        assert again.clock.triggered.is_set()
    assert set(threading.enumerate()) <= before | {threading.current_thread()}


def test_an_address_in_use_is_one_line(episode):
    path, _ = episode
    traj = load_leader_trajectory(path)
    with LeaderPair(traj, LEFT, RIGHT):
        with pytest.raises(UserError, match=r"cannot serve the left leader arm on 127\.0\.0\.31"):
            LeaderPair(traj, LEFT, "127.0.0.33").start()
    with LeaderPair(traj, LEFT, RIGHT):  # the failed pair released what it had bound
        pass


@pytest.mark.parametrize(
    ("left", "right", "match"),
    [
        ("192.168.1.2", RIGHT, r"left leader address '192\.168\.1\.2' is not an IPv4 loopback"),
        (LEFT, "0.0.0.0", r"right leader address '0\.0\.0\.0' is not an IPv4 loopback"),
        (LEFT, "localhost", "not an IPv4 loopback"),
        (LEFT, "::1", "not an IPv4 loopback"),
        (LEFT, LEFT, "need two addresses"),
    ],
)
def test_only_two_loopback_addresses(episode, left, right, match):
    path, _ = episode
    with pytest.raises(UserError, match=match) as exc:
        serve_leaders(str(path), left, right, threading.Event(), say=None)
    assert "\n" not in str(exc.value)


def test_bad_speed_and_missing_episode_are_one_line(episode, tmp_path):
    path, _ = episode
    with pytest.raises(UserError, match=r"replay speed must be a number in \[0\.05, 10\]"):
        serve_leaders(str(path), LEFT, RIGHT, threading.Event(), speed=0.0, say=None)
    with pytest.raises(UserError, match="episode file not found"):
        serve_leaders(str(tmp_path / "nope.hdf5"), LEFT, RIGHT, threading.Event(), say=None)


def test_check_loopback_normalizes():
    assert check_loopback(" 127.0.0.34 ") == "127.0.0.34"
    with pytest.raises(UserError):
        check_loopback("10.0.0.1")
    with pytest.raises(UserError):
        LeaderArmServer(object(), "192.168.1.2")
