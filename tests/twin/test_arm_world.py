"""The served single WidowX AI arm (``twin.arm_world.ArmWorld`` behind a ``ServedKit``):
record's scenes, 7-value frames, and Trossen's ``trossen_arm`` driver moving the arm over
loopback (127.0.0.171 .. 127.0.0.179 in this module); ``serve``'s flags for one arm."""

from __future__ import annotations

import time

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.controller_checks import POSITION
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.twin.arm_adapter import ArmAdapter
from trossen_arm_mujoco.twin.arm_world import ARM_SIDE, ArmWorld

IP = "127.0.0.171"
GOAL = [0.3, 1.2, 1.0, -0.6, 0.2, 0.3, 0.02]


@pytest.fixture
def world():
    made = ArmWorld("pick_place", base_seed=5)
    yield made
    made.close()


def test_episode_k_is_records_scene(world) -> None:
    sampler = registry.make_sampler("pick_place", SamplerSettings())
    try:
        for k in (0, 3):
            world.reset(k)
            task = sampler.next_task(episode_seed(5, k))
            np.testing.assert_allclose(
                world.env_state(), task.scene.objects["cube"].get_pose(task.scene.data)
            )
            np.testing.assert_allclose(world.goal(), task.goal)
            assert world.goal().shape == (3,)
    finally:
        sampler.close()


def test_only_single_arm_tasks() -> None:
    with pytest.raises(UserError, match="not a single-arm task; a served arm holds one of"):
        ArmWorld("sim_transfer_cube")


def test_position_commands_move_the_arm_and_frames_hold_seven_values(world) -> None:
    adapter = ArmAdapter(world, ARM_SIDE)
    values = [(g, 0.0, 0.0) for g in GOAL]
    assert adapter.handle_input([POSITION] * 7, values, time.monotonic()) is None
    frames = []
    world.on_frame = frames.append
    world.advance(2.0)
    np.testing.assert_allclose(world.measured(ARM_SIDE)[:6], GOAL[:6], atol=0.02)
    assert abs(world.measured(ARM_SIDE)[6] - GOAL[6]) < 0.003
    f = frames[-1]
    assert f.qpos.shape == f.qvel.shape == f.action.shape == (7,)
    np.testing.assert_allclose(f.action, GOAL)
    assert f.env_state.shape == (7,) and isinstance(f.success, bool)
    table = adapter.output_table()
    assert table.shape == (7, 6)


def test_the_trossen_arm_driver_moves_the_served_arm(arm_driver) -> None:
    pytest.importorskip("trossen_arm_sim")
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    lines: list[str] = []
    kit = ServedKit(ArmWorld("pick_place"), {ARM_SIDE: IP}, lines.append)
    try:
        kit.start()
        driver = arm_driver(IP)
        assert kit.connected == [ARM_SIDE]
        start = np.asarray(driver.get_all_positions())
        assert start.shape == (7,)
        init = registry.load("pick_place").load_config()["init_arm_qpos"]
        np.testing.assert_allclose(start[:6], init, atol=0.1)  # the task's start (+ noise)
        driver.set_all_positions(GOAL, 1.5, True)  # blocking: returns once there
        end = time.monotonic() + 3.0
        while True:
            pos = np.asarray(driver.get_all_positions())
            err = np.abs(pos - GOAL)
            if (err[:6].max() < 0.02 and err[6] < 0.002) or time.monotonic() > end:
                break
            time.sleep(0.05)
        np.testing.assert_allclose(pos[:6], GOAL[:6], atol=0.02)
        assert abs(pos[6] - GOAL[6]) < 0.002
        assert np.asarray(driver.get_all_velocities()).shape == (7,)
        # a jump past the speed limit faults the arm, as on the real controller
        driver.set_all_positions([GOAL[0] + 1.5, *GOAL[1:]], 0.01, False)
        time.sleep(0.3)
        with pytest.raises(RuntimeError):
            for _ in range(20):
                driver.get_all_positions()
                time.sleep(0.05)
        assert kit.faults and kit.faults[0].startswith(f"{ARM_SIDE} arm:")
        assert any(line.startswith(f"{ARM_SIDE} arm ({IP}): ") for line in lines)
    finally:
        kit.close()
        assert kit.alive_threads == 0


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--task_name", "pick_place", "--right_ip", "127.0.0.172"], "serves one arm"),
        (["--task_name", "sim_transfer_cube", "--ip", "127.0.0.172"], "--ip is a single arm's"),
        (["--task_name", "push", "--record", "x"], "record it with trossen-mujoco record"),
        (["--task_name", "push", "--ip", "10.0.0.2"], "--ip"),
    ],
)
def test_serve_flags_for_one_arm_are_one_line(args, expected, capsys) -> None:
    pytest.importorskip("trossen_arm_sim")
    from trossen_arm_mujoco.scripts.serve import main

    with pytest.raises(UserError, match=expected):
        main(args)
