"""The safety floor of the robot layer: its height checked, its report, every front door's
robot holding one, and the recorded scripted episodes unchanged by it, bit for bit."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.safety_floor import FloorReport, SafetyFloor, floor_height
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings


@pytest.mark.parametrize(
    "table, margin, match",
    [
        (0.0, math.nan, "safety margin must be a number >= 0"),
        (0.0, -0.01, "safety margin must be a number >= 0"),
        (0.0, math.inf, "safety margin must be a number >= 0"),
        (math.nan, 0.0, "table height must be a finite number"),
        (0.0, "1cm", "safety margin must be a number"),
        (True, 0.0, "table height must be a number"),
    ],
)
def test_floor_height_refuses_bad_values_in_one_line(table, margin, match):
    with pytest.raises(UserError, match=match) as err:
        floor_height(table, margin)
    assert "\n" not in str(err.value)


def test_floor_height_and_report():
    assert floor_height(0.02) == 0.02 and floor_height(0.0, 0.01) == 0.01
    report = FloorReport()
    assert not report.clipped and report.links == []
    for link in ("link_4", "link_5", "link_4"):
        report.add(link)
    assert report.clipped and report.links == ["link_4", "link_5"]
    report.clear()
    assert not report.clipped


def test_nan_floor_is_refused():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(UserError, match="safety floor height must be a finite number"):
        SafetyFloor(model, [], floor_z=math.nan)


@pytest.mark.parametrize(
    "name, flavour",
    [
        ("sim_transfer_cube", "joint"),
        ("sim_transfer_cube", "ee"),
        ("sim_insertion", "joint"),
        ("reach", "joint"),
        ("push", "joint"),
    ],
)
def test_samplers_build_robots_with_a_floor_at_the_table_top(name, flavour):
    """Every front door builds its robots through a sampler: the floor is on by default, at
    the table top (``floor_margin=0``); ``floor_margin=None`` leaves it off."""
    with registry.make_sampler(name, SamplerSettings(flavour=flavour)) as sampler:
        robot = sampler.scene.robots[sampler.robot_name]
        floor = robot.safety_floor
        assert floor is not None and floor.floor_z == sampler.config["table_height"]
        arms = {a for a, _ in sampler.arms}
        assert set(floor.arms if flavour == "joint" else floor.tools) == arms
        assert all(c.floor is floor for c in robot.controllers.values())
    with registry.make_sampler(
        name, SamplerSettings(flavour=flavour, floor_margin=0.05)
    ) as sampler:
        floor = sampler.scene.robots[sampler.robot_name].safety_floor
        assert floor.floor_z == pytest.approx(sampler.config["table_height"] + 0.05)
    with registry.make_sampler(
        name, SamplerSettings(flavour=flavour, floor_margin=None)
    ) as sampler:
        robot = sampler.scene.robots[sampler.robot_name]
        assert robot.safety_floor is None and not robot.floor_report.clipped
    with pytest.raises(UserError, match="safety margin"):
        registry.make_sampler(name, SamplerSettings(flavour=flavour, floor_margin=-0.01))


def test_dm_control_envs_hold_a_floor():
    from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask, TrossenAIStationaryEETask
    from trossen_arm_mujoco.sim_env import TransferCubeTask, TrossenAIStationaryTask
    from trossen_arm_mujoco.utils import make_sim_env

    for cls in (
        TransferCubeTask,
        TransferCubeEETask,
        TrossenAIStationaryTask,
        TrossenAIStationaryEETask,
    ):
        env = make_sim_env(cls, cam_list=[], random=0)
        robot = env.task.robot(env.physics)
        assert robot.safety_floor is not None and robot.safety_floor.floor_z == 0.02
        env.close()


def _record(task: str, floor: bool, episode_len: int) -> tuple[np.ndarray, ...]:
    """(actions, qpos, qvel, env_state, rewards) of one scripted episode, both phases, with
    the robots' floors on (the default) or taken off; and how often the floor was asked."""
    from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings

    settings = RecordSettings(task_name=task, episode_len=episode_len, inject_noise=True)
    recorder = EpisodeRecorder(settings)
    asked = [0]
    for scene in (recorder.ee_scene, recorder.joint_scene):
        robot = scene.robots[recorder.joint_sampler.robot_name]
        if not floor:
            robot.set_safety_floor(None)
        elif robot.safety_floor.arms:
            hold = robot.safety_floor.hold

            def counted(data, start, names, hold=hold):
                asked[0] += 1
                return hold(data, start, names)

            robot.safety_floor.hold = counted
    try:
        actions, poses = recorder.scripted_rollout(np.random.default_rng(11))
        rewards = np.empty(len(actions))
        states = []
        for _ in recorder.replay_steps(actions, poses, rewards):
            d = recorder.joint_scene.data
            states.append(np.concatenate([d.qpos, d.qvel, d.ctrl]))
    finally:
        recorder.close()
    return actions, np.array(states), rewards, asked[0]


@pytest.mark.parametrize("task, length", [("sim_transfer_cube", 600), ("sim_insertion", 400)])
def test_recorded_scripted_episodes_are_the_same_with_the_floor(task, length):
    """The scripted demonstrations grasp within a few mm of the table but never below its
    top: the floor (asked every replay tick) changes nothing in what record writes."""
    on = _record(task, True, length)
    off = _record(task, False, length)
    assert on[3] == length  # the floor was consulted at every tick of the joint replay
    for a, b in zip(on[:3], off[:3], strict=True):
        assert np.array_equal(a, b)
    assert on[2][-1] == registry.load(task).task_class().max_reward
