"""Arm drivers: the simulated twin's setpoint and physics, the real backend without hardware."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.clock import SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    HOME_POSE,
    SLEEP_POSE,
    ArmDriver,
    TrossenArmDriver,
    import_trossen_arm,
    resolve_presets,
    split_arms,
)
from trossen_arm_mujoco.real.sim_driver import SimArmDriver


def ready(clock: SimClock | None = None, **kwargs) -> SimArmDriver:
    drv = SimArmDriver(clock, **kwargs)
    drv.configure("127.0.0.1")
    drv.set_all_modes_position()
    return drv


def test_sim_driver_satisfies_protocol_and_starts_asleep() -> None:
    drv = SimArmDriver()
    assert isinstance(drv, ArmDriver)
    pos = drv.get_all_positions()
    assert pos.shape == (7,) and pos.dtype == np.float64
    np.testing.assert_allclose(pos, SLEEP_POSE, atol=1e-12)


def test_commands_refused_before_configure_and_position_mode() -> None:
    drv = SimArmDriver()
    with pytest.raises(RuntimeError, match="not configured"):
        drv.set_all_positions(HOME_POSE, 1.0, False)
    drv.configure("127.0.0.1")
    with pytest.raises(RuntimeError, match="position mode"):
        drv.set_all_positions(HOME_POSE, 1.0, False)
    drv.set_all_modes_position()
    with pytest.raises(ValueError, match="7 positions"):
        drv.set_all_positions([0.0] * 6, 1.0, False)
    with pytest.raises(ValueError, match="finite"):
        drv.set_all_positions([np.nan] + [0.0] * 6, 1.0, False)
    drv.cleanup()
    with pytest.raises(RuntimeError, match="not configured"):
        drv.set_all_positions(HOME_POSE, 1.0, False)


def test_configure_rejects_unknown_presets_listing_valid_ones() -> None:
    drv = SimArmDriver()
    with pytest.raises(UserError, match="valid robot models: wxai_v0"):
        drv.configure("127.0.0.1", model="vxai_v0_left")
    with pytest.raises(UserError, match="wxai_v0_follower"):
        drv.configure("127.0.0.1", end_effector="gripperless")


def test_quintic_setpoint_reaches_goal_at_goal_time_and_arm_lags() -> None:
    clock = SimClock()
    drv = ready(clock)
    drv.set_all_positions(HOME_POSE, 1.0, blocking=False)
    clock.sleep(0.5)
    pos, vel, _ = drv.setpoint()
    # quintic from rest: half way at half time, moving
    np.testing.assert_allclose(pos, np.asarray(HOME_POSE) * 0.5, atol=1e-9)
    assert vel[1] > 0
    meas = drv.get_all_positions()
    assert 0 < meas[1] < HOME_POSE[1]  # physics moved the arm, behind the goal
    clock.sleep(0.5)
    np.testing.assert_allclose(drv.setpoint()[0], HOME_POSE, atol=1e-12)
    assert abs(drv.get_all_positions()[1] - HOME_POSE[1]) > 1e-5  # still lagging at goal_time
    clock.sleep(1.0)
    np.testing.assert_allclose(drv.get_all_positions(), HOME_POSE, atol=2e-3)


def test_linear_and_step_setpoints() -> None:
    clock = SimClock()
    drv = ready(clock)
    goal = np.array([0.1, 0.3, 0.3, 0.1, 0.1, 0.1, 0.02])
    drv.set_all_positions(goal, 0.1, blocking=False)  # <= 0.2 s: linear ramp
    clock.sleep(0.05)
    np.testing.assert_allclose(drv.setpoint()[0], goal * 0.5, atol=1e-9)
    np.testing.assert_allclose(drv.setpoint()[1], goal / 0.1, atol=1e-9)
    clock.sleep(0.1)
    drv.set_all_positions(np.zeros(7), 0.0005, blocking=False)  # below one period: a step
    np.testing.assert_allclose(drv.setpoint()[0], np.zeros(7))


def test_setpoint_is_continuous_when_a_new_goal_interrupts_a_move() -> None:
    clock = SimClock()
    drv = ready(clock)
    drv.set_all_positions(HOME_POSE, 1.0, blocking=False)
    clock.sleep(0.4)
    before = drv.setpoint()
    drv.set_all_positions(np.zeros(7), 0.5, blocking=False)
    after = drv.setpoint()
    for a, b in zip(before, after, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_blocking_advances_the_shared_clock_for_both_arms() -> None:
    clock = SimClock()
    left, right = ready(clock), ready(clock)
    right.set_all_positions(HOME_POSE, 1.0, blocking=False)
    left.set_all_positions(HOME_POSE, 1.0, blocking=True)
    assert clock.now() == pytest.approx(1.0)
    assert left.sim_time == pytest.approx(1.0, abs=0.003)
    assert right.sim_time == pytest.approx(left.sim_time)
    assert right.get_all_positions()[1] > 0.2


def test_gripper_is_one_carriage_travel_and_the_twin_finger_follows() -> None:
    clock = SimClock()
    drv = ready(clock)
    drv.set_all_positions([0, 0, 0, 0, 0, 0, 0.03], 0.5, blocking=True)
    clock.sleep(1.0)
    assert drv.get_all_positions()[6] == pytest.approx(0.03, abs=5e-4)
    twin = drv.data.qpos[drv._twin_qadr]
    assert twin == pytest.approx(0.03, abs=1e-3)


def test_goals_outside_the_actuator_range_are_clamped() -> None:
    drv = ready()
    drv.set_all_positions([0, 0, 0, 0, 0, 0, 0.1], 0.0, blocking=False)
    assert drv.setpoint()[0][6] == pytest.approx(0.044)


def test_split_arms_sends_joints_and_right_carriage() -> None:
    row = np.arange(16, dtype=float)
    left, right = split_arms(row)
    np.testing.assert_array_equal(left, row[0:7])
    np.testing.assert_array_equal(right, row[8:15])
    with pytest.raises(ValueError):
        split_arms(np.zeros(14))


def test_wall_clock_sleeps_in_real_time() -> None:
    clock = WallClock()
    t0 = clock.now()
    clock.sleep(0.01)
    clock.sleep(-1.0)
    assert 0.009 <= clock.now() - t0 < 0.5


def test_trossen_backend_without_package_gives_install_hint(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "trossen_arm", None)  # import fails
    with pytest.raises(UserError, match=r"pip install 'trossen-arm-mujoco\[real\]'") as info:
        TrossenArmDriver()
    assert "\n" not in str(info.value)


def _fake_trossen_arm(with_get_all: bool = True) -> types.ModuleType:
    mod = types.ModuleType("trossen_arm")
    mod.__version__ = "0.0-fake"

    class Model:
        __members__ = {"wxai_v0": "MODEL_WXAI"}
        wxai_v0 = "MODEL_WXAI"

    class StandardEndEffector:
        wxai_v0_follower = "EE_FOLLOWER"
        wxai_v0_leader = "EE_LEADER"

    class Driver:
        def configure(self, *args):  # pragma: no cover - never called
            raise AssertionError("must not be called")

    if with_get_all:
        Driver.get_all_positions = lambda self: [0.0] * 7
    mod.Model, mod.StandardEndEffector, mod.TrossenArmDriver = Model, StandardEndEffector, Driver
    return mod


def test_trossen_presets_default_to_the_follower(monkeypatch: pytest.MonkeyPatch) -> None:
    fake = _fake_trossen_arm()
    monkeypatch.setitem(sys.modules, "trossen_arm", fake)
    ta = import_trossen_arm()
    assert resolve_presets(ta, "wxai_v0", "wxai_v0_follower") == ("MODEL_WXAI", "EE_FOLLOWER")
    with pytest.raises(UserError, match="valid end effectors: wxai_v0_follower, wxai_v0_leader"):
        resolve_presets(ta, "wxai_v0", "wxai_v1")
    drv = TrossenArmDriver()  # constructing only imports: no network, no vendor driver yet
    with pytest.raises(RuntimeError, match="not configured"):
        drv.get_all_positions()
    drv.cleanup()  # idempotent before configure


def test_trossen_package_too_old_is_a_user_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "trossen_arm", _fake_trossen_arm(with_get_all=False))
    with pytest.raises(UserError, match=r"too old .*1\.9\.1"):
        TrossenArmDriver()
