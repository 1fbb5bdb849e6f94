"""Pick and place: a scripted grasp (robot-layer IK) lifts the cube onto an air goal."""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.tasks import registry


def test_scripted_grasp_reaches_air_goal(ik_driver):
    sampler = registry.make_sampler("pick_place")
    try:
        sampler.sample_task(2)
        cube0 = sampler.scene.objects["cube"].get_pose(sampler.scene.data)[:3]
        task = sampler.make_task(goal=cube0 + [0.0, 0.0, 0.1])
        task.reset()
        assert not task.lifted() and not task.judge_success()
        resting = task.get_reward()
        drive = ik_driver(task)
        drive.move_to(cube0 + [0, 0, 0.08], gripper=0.044)
        drive.move_to(cube0 + [0, 0, 0.0], gripper=0.044)
        for _ in range(15):
            task.step({"arm": task.arm.get_ctrl(task.data), "gripper": np.array([0.0])})
        drive.move_to(cube0 + [0, 0, 0.1], gripper=0.0, step=0.005, settle=20)
        assert task.lifted(), task.cube_pos()
        assert task.judge_success(), task.get_info()
        assert task.get_info()["lifted"] is True
        assert task.get_reward() > resting
        assert task.score() == (task.get_reward(), task.get_info())  # bonuses included
    finally:
        sampler.close()


def test_description_mentions_goal():
    sampler = registry.make_sampler("pick_place")
    try:
        task = sampler.make_task(goal=[0.3, 0.1, 0.12])
        assert "(0.300, 0.100, 0.120)" in task.get_task_description()
    finally:
        sampler.close()
