"""JointTargetBatch: the robot's plain joint_position groups rate-limited as one vector give
exactly the controls their controllers give one by one."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config
from trossen_arm_mujoco.robot.controllers import JointPosController
from trossen_arm_mujoco.robot.joint_target_batch import JointTargetBatch, batchable
from trossen_arm_mujoco.robot.robot import Robot

KIT_JOINT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene_joint.xml"


@pytest.fixture
def kit():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    robot = Robot(model, stationary_ai_joint_config(), ctrl_dt=0.02, data=data)
    robot.reset()
    return model, data, robot


def _random_commands(robot: Robot, rng: np.random.Generator) -> dict[str, np.ndarray]:
    out = {}
    for name, controller in robot.controllers.items():
        low, high = controller.group.ctrl_limits()
        out[name] = rng.uniform(low - 0.2, high + 0.2)  # some beyond the range
    return out


def test_batched_controls_equal_the_controllers_one_by_one(kit):
    model, data, robot = kit
    assert all(batchable(c) for c in robot.controllers.values())
    reference = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for _ in range(20):
        commands = _random_commands(robot, rng)
        reference.ctrl[:] = data.ctrl
        expected = {
            name: robot.controllers[name].compute(reference, cmd) for name, cmd in commands.items()
        }
        robot.update_control(commands)
        out = robot.compute_control()
        assert robot._batch[0] is not None and not robot._batch[1]  # one batch, no others
        for name, ctrl in expected.items():
            assert np.array_equal(out[name], ctrl)
            assert np.array_equal(robot.controllers[name].group.get_ctrl(data), ctrl)


def test_a_new_speed_limit_is_picked_up(kit):
    _, data, robot = kit
    arm = robot.view.group("left_arm")
    target = arm.get_ctrl(data) + 1.0
    robot.update_control({"left_arm": target})
    before = arm.get_ctrl(data)
    robot.compute_control()
    assert np.allclose(arm.get_ctrl(data) - before, np.minimum(arm.velocity_limits * 0.02, 1.0))
    arm.set_velocity_limits(np.full(6, 0.5))
    robot.update_control({"left_arm": target})
    before = arm.get_ctrl(data)
    robot.compute_control()
    assert np.allclose(arm.get_ctrl(data) - before, 0.5 * 0.02)


def test_a_subclassed_controller_is_run_on_its_own(kit):
    _, data, robot = kit

    class Halved(JointPosController):
        def _target(self, data, cmd):
            return 0.5 * cmd

    group = robot.view.group("right_arm")
    robot.controllers["right_arm"] = Halved(group, robot.model, ctrl_dt=0.02)
    assert not batchable(robot.controllers["right_arm"])
    robot.update_control({"left_arm": np.zeros(6), "right_arm": np.full(6, 0.02)})
    for _ in range(20):  # enough ticks to get there at the speed limits
        robot.compute_control()
    batch, others = robot._batch
    assert batch.names == ("left_arm",) and others == ["right_arm"]
    assert np.allclose(group.get_ctrl(data), 0.01)  # the subclass's target, reached


def test_set_target_takes_the_commands_in_batch_order(kit):
    _, data, robot = kit
    batch = JointTargetBatch(robot.controllers, ["right_gripper", "left_arm"])
    batch.set_target({"left_arm": np.zeros(6), "right_gripper": np.array([0.02])})
    out = batch.apply(data)
    assert list(out) == ["right_gripper", "left_arm"]
    assert out["right_gripper"].shape == (1,) and out["left_arm"].shape == (6,)
