"""The real backend (``TrossenArmDriver`` over the installed ``trossen_arm``) against the
simulated kit served on loopback (127.0.0.51 / 127.0.0.52): the controller's error state as
the real driver raises it, its recovery, and replay's safe exit after a fault."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

pytest.importorskip("trossen_arm_sim")
pytest.importorskip("trossen_arm")

from trossen_arm_mujoco.real.clock import WallClock  # noqa: E402
from trossen_arm_mujoco.real.controller_checks import controller_limits as served_limits  # noqa: E402
from trossen_arm_mujoco.real.driver import TrossenArmDriver  # noqa: E402
from trossen_arm_mujoco.real.replay import ReplayConfig, make_drivers, replay  # noqa: E402
from trossen_arm_mujoco.real.validate import validate_actions  # noqa: E402
from trossen_arm_mujoco.twin.kit_world import KitWorld  # noqa: E402
from trossen_arm_mujoco.twin.served_kit import ServedKit  # noqa: E402

IPS = {"left": "127.0.0.51", "right": "127.0.0.52"}


@pytest.fixture
def kit() -> Iterator[ServedKit]:
    served = ServedKit(KitWorld(), IPS).start()
    yield served
    served.close()
    assert served.alive_threads == 0


def connected(side: str) -> TrossenArmDriver:
    driver = TrossenArmDriver()
    driver.configure(IPS[side])
    driver.set_all_modes_position()
    return driver


def test_error_state_and_recover_with_the_real_driver(kit: ServedKit) -> None:
    driver = connected("left")
    try:
        assert driver.error_state() is None and driver.recover() is None
        here = driver.get_all_positions()
        kit.servers["left"].fault(15, "joint_0: test fault")  # JOINT_LIMIT_EXCEEDED
        time.sleep(0.2)  # the driver learns of it from its next robot output
        with pytest.raises(RuntimeError, match="Joint limit exceeded"):
            driver.set_all_positions(here, 0.5, True)
        name, info = driver.error_state()
        assert name == "joint_limit_exceeded" and "joint_0: test fault" in info
        assert "\n" not in info
        line = driver.recover()
        assert line is not None and line.startswith("cleared the controller's error state")
        assert kit.servers["left"].error_state == 0 and driver.error_state() is None
        driver.set_all_positions(here, 0.5, True)  # moves again, in position mode
        # an error of the hardware is not cleared automatically
        kit.servers["left"].fault(10, "rotor at 90 C")  # JOINT_OVERHEATED
        time.sleep(0.2)
        with pytest.raises(RuntimeError, match="joint_overheated not cleared"):
            driver.recover()
    finally:
        driver.cleanup()


def test_replay_after_a_fault_takes_every_arm_home(kit: ServedKit, smooth: Any) -> None:
    limits = served_limits()
    limits[0].position_max = 0.1  # the episode swings joint_0 to 0.3 rad
    kit.adapters["left"].set_limits(limits)
    trajectory = validate_actions(smooth(20, 10.0), 10.0)
    drivers, clock = make_drivers("wire")
    assert isinstance(clock, WallClock)
    config = ReplayConfig(fps=10.0, ips=IPS, progress=False, settle_time=0.2)
    result = replay(trajectory, drivers, clock, config)
    assert result.status == "failed" and result.exit_code == 1
    assert "Joint limit exceeded" in result.reason and 0 < result.steps_done < 20
    assert len(result.recovered) == 1 and result.recovered[0].startswith("left arm: cleared")
    assert result.arms_safe and result.configured == ["left", "right"]
    for pos in result.final_positions.values():
        np.testing.assert_allclose(pos[:6], 0.0, atol=0.03)
    end = time.monotonic() + 2.0
    while kit.connected and time.monotonic() < end:  # the servers see the clients leave
        time.sleep(0.05)
    assert kit.connected == []  # both cleaned up
