"""The served kit's world and one arm of it, stepped without pacing (no network)."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.controller_checks import (
    EFFORT,
    EXTERNAL_EFFORT,
    POSITION,
    VELOCITY,
    controller_limits,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.twin.arm_adapter import ArmAdapter
from trossen_arm_mujoco.twin.kit_world import KitWorld

GOAL = np.array([0.3, 0.6, 0.5, 0.2, -0.2, 0.3, 0.03])


@pytest.fixture(scope="module")
def world():
    w = KitWorld("sim_transfer_cube", base_seed=7)
    yield w
    w.close()


def feed(adapter: ArmAdapter, modes, values, seconds: float, t0: float = 0.0) -> float:
    """Robot inputs every 2 ms for ``seconds`` (as the driver streams them), stepping the
    world between them; returns the last input time."""
    t = t0
    for _ in range(int(round(seconds / 0.02))):
        for _ in range(10):
            fault = adapter.handle_input(modes, values, t)
            assert fault is None, fault
            t += 0.002
        adapter.world.advance(0.02)
    return t


@pytest.mark.parametrize("task", ["sim_transfer_cube", "sim_insertion"])
@pytest.mark.parametrize(("seed", "index"), [(0, 0), (3, 5)])
def test_scene_is_records_episode(task: str, seed: int, index: int) -> None:
    """Episode k of base seed S: the objects where record --seed S's rollout of episode k
    put them (its end-effector sampler, seeded with episode_seed(S, k))."""
    world = KitWorld(task, base_seed=seed, episode_index=index)
    with registry.make_sampler(task, SamplerSettings(flavour="ee")) as ee:
        rng = np.random.default_rng(episode_seed(seed, index))
        expected = ee.next_task(rng).object_poses()
    got = world.object_poses()
    assert list(got) == list(expected)
    for name in got:
        np.testing.assert_array_equal(got[name], expected[name])
    world.reset(index + 1)
    assert not np.allclose(world.env_state(), np.concatenate(list(got.values())))
    world.close()


def test_the_served_scene_is_drawn_with_the_looks_asked_for() -> None:
    from trossen_arm_mujoco.sim.looks import SceneLooks

    plain = KitWorld("sim_transfer_cube", looks=SceneLooks(shadows=False, antialias=False))
    try:
        assert plain.model.vis.quality.offsamples == 0 and not plain.model.light_castshadow.any()
    finally:
        plain.close()
    with pytest.raises(UserError, match="looks must be a SceneLooks"):
        KitWorld("sim_transfer_cube", looks="plain")


def test_only_kit_tasks_and_whole_frame_rates() -> None:
    assert {"sim_transfer_cube", "sim_insertion"} <= set(registry.kit_names())
    assert not {"reach", "push", "pick_place"} & set(registry.kit_names())
    with pytest.raises(UserError, match="not a Stationary AI"):
        KitWorld("reach")
    with pytest.raises(UserError, match="whole multiple.*e.g. --fps 250, 125, 100, 50"):
        KitWorld(fps=30)


def test_position_mode_tracks_and_records_the_targets(world: KitWorld) -> None:
    left = ArmAdapter(world, "left")
    world.reset(0)
    goal = GOAL.copy()
    goal[6] = 0.044  # above the controller's range: clipped to 0.04 m, as the real arm does
    feed(left, [POSITION] * 7, [(g, 0.0, 0.0) for g in goal], 1.5)
    pos = world.measured("left")
    np.testing.assert_allclose(pos[:6], GOAL[:6], atol=0.02)
    assert pos[6] == pytest.approx(GRIPPER_MAX, abs=0.002)
    action = world.action()
    np.testing.assert_allclose(action[VENDOR16_LAYOUT.arm("left")], GOAL[:6])
    np.testing.assert_allclose(action[VENDOR16_LAYOUT.fingers("left")], GRIPPER_MAX)
    right = world.measured("right")  # untouched: holds its start
    np.testing.assert_allclose(right[:3], [0.0, np.pi / 12, np.pi / 12], atol=0.01)
    table = left.output_table()  # the wire layout of the robot output, per joint
    assert table.shape == (7, 6) and table.dtype == np.dtype("<f4")
    assert table[0, 0] == pytest.approx(pos[0], abs=1e-5) and table[0, 4] == 40.0


def test_velocity_mode_integrates_and_faults_at_a_limit(world: KitWorld) -> None:
    adapter = ArmAdapter(world, "right")
    world.reset(0)
    start = world.measured("right")
    adapter.set_modes([VELOCITY] * 7)
    speed = np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0, -0.02])
    feed(adapter, [VELOCITY] * 7, [(0.0, v, 0.0) for v in speed], 0.5)
    target = world.arms["right"].target
    assert target[0] == pytest.approx(start[0] + 0.2, abs=0.01)
    # the open gripper (0.044 m) starts from the controller's top, 0.04 m
    assert target[6] == pytest.approx(min(start[6], GRIPPER_MAX) - 0.01, abs=0.001)
    assert world.measured("right")[0] == pytest.approx(start[0] + 0.2, abs=0.03)
    # joint_1 runs into its lower limit (0 rad) at -3 rad/s within 0.1 s
    fault, t = None, 10.0
    down = [(0.0, 0.0, 0.0), (0.0, -3.0, 0.0)] + [(0.0, 0.0, 0.0)] * 5
    for _ in range(200):
        fault = adapter.handle_input([VELOCITY] * 7, down, t)
        if fault is not None:
            break
        t += 0.002
    assert fault is not None and "joint_1: velocity command drove the joint" in fault.reason
    assert (world.arms["right"].modes == 0).all()


def test_a_jump_faults_and_stops_the_arm(world: KitWorld) -> None:
    """A goal_time=0 jump of 1 rad: the target runs ahead of the rate-limited setpoint."""
    adapter = ArmAdapter(world, "left")
    world.reset(0)
    faults = []
    world.on_fault = lambda side, fault: (faults.append((side, fault)), adapter.idle())
    try:
        start = world.measured("left")
        small = start.copy()
        small[0] += 0.3  # 90 ms at the speed limit: within the lag allowed
        feed(adapter, [POSITION] * 7, [(p, 0.0, 0.0) for p in small], 0.2)
        assert not faults
        jump = small.copy()
        jump[0] += 1.0
        feed(adapter, [POSITION] * 7, [(p, 0.0, 0.0) for p in jump], 0.04)
    finally:
        world.on_fault = None
    assert faults and faults[0][0] == "left" and "ahead of the setpoint" in faults[0][1].reason
    world.advance(0.3)
    assert world.measured("left")[0] < small[0] + 0.3  # stopped, not carried on to the jump


def test_external_effort_is_limp_and_effort_is_uncompensated(world: KitWorld) -> None:
    adapter = ArmAdapter(world, "left")
    world.reset(0)
    start = world.measured("left")
    zero = [(0.0, 0.0, 0.0)] * 7
    feed(adapter, [EXTERNAL_EFFORT] * 7, zero, 0.5)
    np.testing.assert_allclose(world.measured("left")[:6], start[:6], atol=0.02)
    push = [(0.0, 0.0, 3.0)] + zero[1:]  # 3 N m on joint_0 turns it against the damping
    feed(adapter, [EXTERNAL_EFFORT] * 7, push, 0.5)
    assert world.measured("left")[0] > start[0] + 0.05
    world.reset(0)
    feed(adapter, [EFFORT] * 7, zero, 0.5)  # no gravity compensation: the arm sags
    assert np.abs(world.measured("left")[1:3] - start[1:3]).max() > 0.05


def test_frames_and_a_new_episode_keeping_the_arms(world: KitWorld) -> None:
    frames = []
    world.reset(0)
    world.on_frame = frames.append
    try:
        world.advance(0.1)
    finally:
        world.on_frame = None
    assert len(frames) == 5
    f = frames[-1]
    assert f.qpos.shape == f.qvel.shape == f.action.shape == (16,)
    assert f.env_state.shape == (7,) and f.qpos_full.shape == (world.model.nq,)
    assert isinstance(f.reward, float) and f.reward == 0.0 and not f.success
    world.arms["left"].target[0] = 0.4
    world.advance(1.0)
    arms, objects = world.measured("left"), world.env_state()
    world.reset(1, keep_arms=True)
    np.testing.assert_allclose(world.measured("left"), arms)
    assert world.arms["left"].target[0] == 0.4
    assert not np.allclose(world.env_state(), objects)
    assert world.seed == episode_seed(7, 1)


def test_a_joint_sunk_past_its_stop_reports_the_stop(world: KitWorld) -> None:
    """MuJoCo's soft limits let the closed gripper sink about 1 mm below 0; the served arm
    reports its hard stop (a position its controller accepts back as a command)."""
    left = ArmAdapter(world, "left")
    world.reset(0)
    goal = GOAL.copy()
    goal[6] = 0.0
    feed(left, [POSITION] * 7, [(g, 0.0, 0.0) for g in goal], 1.0)
    assert left.output_table()[6, 0] >= 0.0
    with world.lock:
        world.data.qpos[world.qadr["left"][6]] = -0.0012  # sunk past the stop
        world.data.qpos[world.qadr["left"][1]] = -0.02  # joint_1 below its 0 rad stop
    table = left.output_table()
    assert table[6, 0] == 0.0 and table[1, 0] == 0.0
    lims = controller_limits()
    assert all(lim.position_min <= v <= lim.position_max for lim, v in zip(lims, table[:, 0]))
