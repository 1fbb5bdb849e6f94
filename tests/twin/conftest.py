"""Fixtures of the served-kit tests: a served kit in this process, and real ``trossen_arm``
drivers connected to it, all on loopback addresses and all stopped at teardown.

Every test module that serves or connects uses its own loopback addresses (ports are fixed per
address: TCP 50001, UDP 50000), so modules never clash, even run at the same time, and none
uses the package's defaults (127.0.0.2 .. 127.0.0.5) that a ``trossen-mujoco serve`` on this
machine may hold. The allocation, one block of ten a module:

============================================  ===========================
module                                        addresses
============================================  ===========================
tests/twin/test_leaders.py                    127.0.0.31 .. 127.0.0.39
tests/twin/test_arm_server.py                 127.0.0.41 .. 127.0.0.49
tests/real/test_wire_recover.py               127.0.0.51 .. 127.0.0.59
tests/scripts/test_serve.py                   127.0.0.61 .. 127.0.0.69
tests/scripts/test_teleop.py                  127.0.0.71 .. 127.0.0.79
tests/scripts/test_replay_episode_real.py     127.0.0.81 .. 127.0.0.89
tests/twin/test_leader_staging.py             127.0.0.91 .. 127.0.0.99
tests/test_examples.py                        127.0.0.101 .. 127.0.0.109
tests/scripts/test_serve_signals.py           127.0.0.111 .. 127.0.0.119
tests/real/test_exit_clean.py                 127.0.0.121 .. 127.0.0.129
tests/eval/test_wire_backend.py               127.0.0.131 .. 127.0.0.139
tests/scripts/test_serve_rehearsal.py         127.0.0.141 .. 127.0.0.149
tests/eval/test_checkpoint_files.py           127.0.0.161 .. 127.0.0.169
tests/twin/test_arm_world.py                  127.0.0.171 .. 127.0.0.179
tests/eval/test_arm_wire.py                   127.0.0.181 .. 127.0.0.189
tests/eval/test_lerobot_arm.py                127.0.0.191 .. 127.0.0.199
============================================  ===========================

(tests/twin/test_kit_world.py, test_session_recorder.py, test_episode_spool.py and
test_faults.py serve nothing; test_camera_stream.py and test_episode_control.py serve only
on 127.0.0.1, on free ports.)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

#: Arm controller model and end-effector preset the tests configure.
MODEL, END_EFFECTOR = "wxai_v0", "wxai_v0_follower"


@pytest.fixture
def served_kit() -> Iterator[Callable[..., Any]]:
    """``served_kit(left_ip, right_ip, **world_kwargs)``: a started ``ServedKit`` over a
    fresh ``KitWorld``; every kit made is closed at teardown (its threads joined)."""
    pytest.importorskip("trossen_arm_sim")
    from trossen_arm_mujoco.twin.kit_world import KitWorld
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    kits: list[Any] = []

    def make(left: str, right: str, say: Callable[[str], None] | None = None, **kwargs: Any):
        kit = ServedKit(KitWorld(**kwargs), {"left": left, "right": right}, say)
        kits.append(kit)
        return kit.start()

    yield make
    for kit in kits:
        kit.close()
        assert kit.alive_threads == 0


@pytest.fixture
def arm_driver() -> Iterator[Callable[[str], Any]]:
    """``arm_driver(ip)``: a ``trossen_arm.TrossenArmDriver`` configured against ``ip`` (a
    served arm), in position mode; cleaned up at teardown."""
    ta = pytest.importorskip("trossen_arm")
    drivers: list[Any] = []

    def connect(ip: str, position_mode: bool = True) -> Any:
        assert ip.startswith("127."), "tests only ever connect to loopback addresses"
        driver = ta.TrossenArmDriver()
        end_effector = getattr(ta.StandardEndEffector, END_EFFECTOR)
        driver.configure(getattr(ta.Model, MODEL), end_effector, ip, True, 5.0)
        drivers.append(driver)
        if position_mode:
            driver.set_all_modes(ta.Mode.position)
        return driver

    yield connect
    for driver in drivers:
        try:
            driver.cleanup()
        except Exception:
            pass
