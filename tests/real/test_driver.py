"""Arm drivers: the simulated twin's setpoint and physics, the real backend without hardware."""

from __future__ import annotations

import importlib.metadata
import sys
import time
import types

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.clock import SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    DEFAULT_END_EFFECTOR,
    HOME_POSE,
    SLEEP_POSE,
    ArmDriver,
    TrossenArmDriver,
    check_end_effector,
    end_effector_presets,
    import_trossen_arm,
    installed_version,
    resolve_presets,
    split_arms,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX, clamp_gripper
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


def test_realtime_sim_clock_paces_the_twin_to_the_wall_clock() -> None:
    fast, paced = SimClock(), SimClock(realtime=True)
    arms = [SimArmDriver(fast), SimArmDriver(paced)]
    t0 = time.monotonic()
    fast.sleep(0.2)
    assert time.monotonic() - t0 < 0.2  # as fast as it simulates
    t0 = time.monotonic()
    for _ in range(4):
        paced.sleep(0.05)
    assert 0.2 <= time.monotonic() - t0 < 1.0
    assert paced.now() == pytest.approx(0.2) and arms[1].sim_time == pytest.approx(0.2)


def test_trossen_backend_without_package_gives_install_hint(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "trossen_arm", None)  # import fails
    with pytest.raises(UserError, match=r"pip install 'trossen-arm-mujoco\[real\]'") as info:
        TrossenArmDriver()
    assert "\n" not in str(info.value)


def _fake_trossen_arm(with_get_all: bool = True) -> types.ModuleType:
    mod = types.ModuleType("trossen_arm")
    mod.__version__ = "9.9-not-read"  # the real package has none; metadata is what counts

    class Model:
        __members__ = {"wxai_v0": "MODEL_WXAI"}
        wxai_v0 = "MODEL_WXAI"

    class StandardEndEffector:
        wxai_v0_follower = "EE_FOLLOWER"
        wxai_v0_leader = "EE_LEADER"

        def helper(self):  # pragma: no cover - a method is not a preset
            return None

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


@pytest.mark.parametrize(("installed", "shown"), [("1.8.2", "1.8.2"), (None, "unknown")])
def test_trossen_package_too_old_names_the_version_from_its_metadata(
    installed: str | None, shown: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    asked: list[str] = []

    def version(name: str) -> str:
        asked.append(name)
        if installed is None:
            raise importlib.metadata.PackageNotFoundError(name)
        return installed

    monkeypatch.setattr(importlib.metadata, "version", version)
    monkeypatch.setitem(sys.modules, "trossen_arm", _fake_trossen_arm(with_get_all=False))
    with pytest.raises(UserError, match=r"too old .*1\.9\.1") as info:
        TrossenArmDriver()
    assert str(info.value).startswith(f"trossen_arm {shown} is too old")
    assert "9.9-not-read" not in str(info.value) and asked == ["trossen_arm"]


def test_installed_version_reads_the_real_metadata() -> None:
    pytest.importorskip("trossen_arm")
    assert installed_version() == importlib.metadata.version("trossen_arm") != "unknown"
    assert installed_version("no-such-package-xyz") == "unknown"


def test_end_effector_presets_of_a_fake_package(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(importlib.metadata, "version", lambda name: "0.1.0")
    fake = _fake_trossen_arm()
    assert end_effector_presets(fake) == ["wxai_v0_follower", "wxai_v0_leader"]  # no methods
    with pytest.raises(UserError) as info:
        check_end_effector(fake, "wxai_v0_follower_20250509")
    assert str(info.value) == (
        "unknown end effector 'wxai_v0_follower_20250509'; valid end effectors: "
        "wxai_v0_follower, wxai_v0_leader (StandardEndEffector presets of the installed "
        "trossen_arm 0.1.0)"
    )


def test_end_effector_presets_of_the_installed_package() -> None:
    ta = pytest.importorskip("trossen_arm")
    names = end_effector_presets(ta)
    expected = sorted(
        n
        for n in dir(ta.StandardEndEffector)
        if isinstance(getattr(ta.StandardEndEffector, n), ta.EndEffector)
    )
    assert names == expected and DEFAULT_END_EFFECTOR in names
    if "wxai_v0_follower_20250509" in names:  # trossen_arm >= 1.11: dated presets
        check_end_effector(ta, "wxai_v0_follower_20250509")
    with pytest.raises(UserError, match="valid end effectors: .*wxai_v0_follower") as info:
        check_end_effector(ta, "wxai_v0_gripper")
    assert "\n" not in str(info.value)


def test_clamp_gripper_counts_per_arm_and_leaves_the_input_alone() -> None:
    commands = np.zeros((4, 2, 7))
    commands[:, 0, 6] = [0.03, 0.04, 0.041, 0.044]  # left: 2 above (0.04 itself is fine)
    commands[:, 1, 6] = [0.044, 0.0, 0.0, 0.0]  # right: 1 above
    commands[:, :, 2] = 0.5  # joints are never touched
    before = commands.copy()
    out, clamp = clamp_gripper(commands)
    np.testing.assert_array_equal(commands, before)
    assert out[:, :, 6].max() == GRIPPER_MAX == clamp.gripper_max == 0.04
    np.testing.assert_array_equal(out[:, :, 2], 0.5)
    assert (clamp.count, clamp.total, clamp.per_arm) == (3, 8, {"left": 2, "right": 1})
    assert clamp.max_excess == pytest.approx(0.004)
    assert clamp.as_dict()["gripper_clamped"] == 3
    assert clamp.describe() == (
        "gripper commands above --gripper_max 0.04 m: 3 of 8 clamped to it "
        "(left 2, right 1; largest excess 4.00 mm)"
    )
    none = clamp_gripper(commands, 0.044)[1]
    assert none.count == 0 and none.max_excess == 0.0
    assert none.describe() == "gripper commands above --gripper_max 0.044 m: none (0 of 8 clamped)"
