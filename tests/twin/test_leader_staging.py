"""Served leader arms staged as Trossen's LeRobot leader teleoperator stages them: position
mode, ``set_all_positions(staged, 2 s)``, then ``external_effort`` with zero efforts. A played
arm follows those position commands until its replay is triggered, rests there, then moves
smoothly to the episode's first pose before playing it, so a follower copying it from the
staged pose on never jumps. Loopback addresses 127.0.0.91 .. 127.0.0.99 (the allocation is in
``tests/twin/conftest.py``)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.real.validate import ArmLimits
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE
from trossen_arm_mujoco.twin.leader_trajectory import LeaderTrajectory
from trossen_arm_mujoco.twin.leaders import (
    APPROACH_SPEED_FRACTION,
    POSITION_MODE,
    PlayedLeaderArm,
    serve_leaders,
)
from trossen_arm_mujoco.twin.replay_clock import ReplayClock

ta = pytest.importorskip("trossen_arm")
pytest.importorskip("trossen_arm_sim")

LEFT, RIGHT = "127.0.0.91", "127.0.0.92"
#: The LeRobot plugin's staged pose of a WidowX AI arm (rad x6, gripper m).
STAGED = [0.0, np.pi / 3, np.pi / 6, np.pi / 5, 0.0, 0.0, 0.0]


def make_episode(path, steps: int = 26) -> np.ndarray:
    """0.5 s at 50 Hz from the kit's start pose (grippers open 44 mm): left joint_0 sweeps
    0 -> 0.5 rad, the left gripper 10 -> 30 mm; returns the actions (T, 16)."""
    actions = np.tile(np.asarray(START_ARM_POSE, dtype=float), (steps, 1))
    actions[:, 0] = np.linspace(0.0, 0.5, steps)
    actions[:, 6] = actions[:, 7] = np.linspace(0.01, 0.03, steps)
    attrs = {"task_name": "t", "seed": 0, "success": True}
    with EpisodeWriter(path, episode_len=steps, attrs=attrs) as writer:
        for row in actions:
            writer.append(row, np.zeros(16), row, 0.0, np.zeros(7))
    return actions.astype(np.float32).astype(float)


def test_staged_leaders_rest_there_then_approach_the_episode(tmp_path):
    path = tmp_path / "episode_0.hdf5"
    kit = KIT14_LAYOUT.from_vendor(make_episode(path))
    first = {"left": kit[0, 0:7], "right": kit[0, 7:14]}
    speed_limit = ArmLimits.from_mjcf().velocity
    stop, pairs = threading.Event(), []
    kwargs = {"lead_in": 0.3, "say": None, "on_ready": pairs.append}
    thread = threading.Thread(
        target=serve_leaders, args=(str(path), LEFT, RIGHT, stop), kwargs=kwargs
    )
    thread.start()
    drivers = {}
    try:
        deadline = time.monotonic() + 20
        while not pairs and thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.01)
        pair = pairs[0]
        for side, ip in (("left", LEFT), ("right", RIGHT)):  # the plugin's connect, per arm
            driver = ta.TrossenArmDriver()
            driver.configure(ta.Model.wxai_v0, ta.StandardEndEffector.wxai_v0_leader, ip, True, 5.0)
            drivers[side] = driver
            np.testing.assert_allclose(driver.get_all_positions(), first[side], atol=1e-5)
            driver.set_all_modes(ta.Mode.position)
            driver.set_all_positions(STAGED, 0.5, True)
            time.sleep(0.05)
            np.testing.assert_allclose(driver.get_all_positions(), STAGED, atol=1e-4)
            driver.set_all_modes(ta.Mode.external_effort)
            driver.set_all_external_efforts([0.0] * 7, 0.0, True)
        assert pair.clock.triggered.wait(2.0)
        # both arms approach together, as long as the slower needs: here the right gripper
        # (0 -> 0.044 m at half of 0.0875 m/s, its peak 1.5x the mean speed: 1.5 s)
        need = (
            max(float(np.max(1.5 * np.abs(first[s] - STAGED) / speed_limit)) for s in first)
            / APPROACH_SPEED_FRACTION
        )
        assert pair.clock.approach_s == pytest.approx(need, rel=1e-6)
        # commands after the trigger move nothing: position mode again, another pose
        drivers["left"].set_all_modes(ta.Mode.position)
        drivers["left"].set_all_positions([0.3, 1.0, 1.0, 0.2, 0.0, 0.0, 0.04], 0.05, True)
        samples = []  # (time, positions, velocities) of both arms until the episode is over
        while not pair.finished.is_set() and time.monotonic() < deadline:
            outs = [drivers[side].get_robot_output().joint.all for side in ("left", "right")]
            samples.append(
                (
                    time.monotonic(),
                    [list(o.positions) for o in outs],
                    [list(o.velocities) for o in outs],
                )
            )
            time.sleep(0.005)
        assert pair.finished.is_set()
        t = np.array([s[0] for s in samples])
        pos = np.array([s[1] for s in samples])
        vel = np.array([s[2] for s in samples])
        # it left the staged pose without a jump (exactly: test_played_arm_has_no_jump): no
        # step between reads beyond the speed limits, allowing 50 ms for how old the driver's
        # reading may be on a busy machine (a jump to the first pose would be 0.26 rad and
        # more on joint_1..3)
        steps = np.abs(np.diff(pos, axis=0)) / (np.diff(t) + 0.05)[:, None, None]
        assert np.all(steps <= speed_limit), steps.max(axis=0)
        np.testing.assert_allclose(pos[0], [STAGED, STAGED], atol=1e-4)
        # the reported velocities: at most half the limits while approaching (and close to
        # that on the slowest joint: a smoothstep's peak), within the limits throughout
        start, approach = pair.clock.start_time, pair.clock.approach_s
        moving = (t > start + 0.01) & (t < start + approach - 0.01)
        assert moving.sum() > 10
        fraction = np.abs(vel[moving]) / speed_limit
        assert fraction.max() <= APPROACH_SPEED_FRACTION + 1e-6 and fraction.max() > 0.4
        assert np.all(np.abs(vel) <= speed_limit)
        time.sleep(0.1)
        np.testing.assert_allclose(drivers["left"].get_all_positions(), kit[-1, 0:7], atol=1e-5)
        np.testing.assert_allclose(drivers["right"].get_all_positions(), kit[-1, 7:14], atol=1e-5)
    finally:
        for driver in drivers.values():
            driver.cleanup()
        stop.set()
        thread.join(10)
    assert not thread.is_alive()


def test_played_arm_has_no_jump(tmp_path):
    """Rest at the staged pose, approach, play: sampled every millisecond on a fake clock,
    no step is faster than the speed limits (the approach at most half of them)."""
    limits = ArmLimits.from_mjcf()
    speed_limit = np.asarray(limits.velocity)
    first = np.asarray(START_ARM_POSE[:7], dtype=float)
    positions = np.stack([np.tile(first, (26, 1))] * 2, axis=1)  # (T, 2, 7)
    positions[:, 0, 0] = np.linspace(0.0, 0.5, 26)  # left joint_0 sweeps in 0.5 s
    trajectory = LeaderTrajectory(positions, 0.02, tmp_path / "e.hdf5")
    now = [0.0]
    clock = ReplayClock(trajectory.duration, 1.0, 0.5, now=lambda: now[0])
    arm = PlayedLeaderArm(trajectory, "left", clock, limits)
    clock.approach = arm.approach_time
    arm.apply_joint_commands([POSITION_MODE] * 7, STAGED)
    np.testing.assert_allclose(arm.now()[0], STAGED)  # rests where it was staged
    clock.trigger()
    times = np.arange(0.0, 0.5 + clock.approach_s + trajectory.duration + 0.1, 0.001)
    samples = []
    for t in times:
        now[0] = t
        samples.append(arm.now())
    pos = np.array([p for p, _ in samples])
    vel = np.array([v for _, v in samples])
    np.testing.assert_allclose(pos[0], STAGED)
    np.testing.assert_allclose(pos[-1], positions[-1, 0], atol=1e-12)
    assert np.all(np.abs(np.diff(pos, axis=0)) / 0.001 <= speed_limit * (1 + 1e-9))
    approaching = (times > 0.5) & (times < 0.5 + clock.approach_s)
    assert np.abs(vel[approaching]).max(axis=0) @ (1 / speed_limit) > 0
    assert np.all(np.abs(vel[approaching]) <= APPROACH_SPEED_FRACTION * speed_limit + 1e-9)


def test_serve_lead_in_needs_the_leader_role():
    from trossen_arm_mujoco.errors import UserError
    from trossen_arm_mujoco.scripts import serve

    assert serve.build_parser().parse_args(["--role", "leader", "--lead_in", "8"]).lead_in == 8.0
    with pytest.raises(UserError, match="--lead_in needs --role leader"):
        serve.main(["--lead_in", "8"])
