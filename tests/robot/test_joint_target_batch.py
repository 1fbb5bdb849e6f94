"""JointTargetBatch: the robot's plain joint_position groups rate-limited as one vector give
exactly the controls their controllers give one by one."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config
from trossen_arm_mujoco.robot.controllers import JointPosController
from trossen_arm_mujoco.robot.joint_target_batch import JointTargetBatch, JointTargets, batchable
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
        low, high = controller.group.ctrl_limits.T
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
    arm = robot.view.get_move_group("left_arm")
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

    group = robot.view.get_move_group("right_arm")
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
    out = batch.by_group(batch.apply(data))
    assert list(out) == ["right_gripper", "left_arm"]
    assert out["right_gripper"].shape == (1,) and out["left_arm"].shape == (6,)


# -- JointTargets: the commands of a batch as one vector ------------------------------------
NAMES = ("left_arm", "left_gripper", "right_arm", "right_gripper")


def _twin(model, data):
    """A second robot on a copy of ``data``: the reference, fed plain dicts."""
    twin_data = mujoco.MjData(model)
    mujoco.mj_copyData(twin_data, model, data)
    return Robot(model, stationary_ai_joint_config(), ctrl_dt=0.02, data=twin_data), twin_data


def test_joint_targets_give_the_controls_of_plain_dicts(kit):
    model, data, robot = kit
    twin, twin_data = _twin(model, data)
    batch = robot.joint_target_batch(NAMES)
    assert batch is not None and batch.size == 14
    rng = np.random.default_rng(1)
    for _ in range(10):
        commands = _random_commands(robot, rng)
        vector = np.concatenate([commands[n] for n in NAMES])
        targets = batch.commands(vector)
        assert isinstance(targets, JointTargets) and list(targets) == list(NAMES)
        robot.update_control(targets)
        twin.update_control({n: commands[n] for n in NAMES})
        for _ in range(3):
            out, expected = robot.compute_control(), twin.compute_control()
            assert np.array_equal(data.ctrl, twin_data.ctrl)
            assert all(np.array_equal(out[n], expected[n]) for n in NAMES)
        assert robot._batch[0] is batch  # taken as is, no batch rebuilt


def test_preview_is_the_controllers_limit_over_the_ticks(kit):
    model, data, robot = kit
    batch = robot.joint_target_batch(NAMES)
    rng = np.random.default_rng(2)
    data.ctrl[:] = rng.uniform(-0.5, 0.5, model.nu)
    before = data.ctrl.copy()
    for ticks in (1, 2, 5):
        commands = _random_commands(robot, rng)
        end = batch.preview(data, np.concatenate([commands[n] for n in NAMES]), ticks)
        expected = [robot.controllers[n].limit(data, commands[n], ticks) for n in NAMES]
        assert np.array_equal(end, np.concatenate(expected))
    assert np.array_equal(data.ctrl, before)  # nothing written


def test_a_kept_preview_is_the_next_tick(kit, monkeypatch):
    """preview(keep=True) of the target handed over is what the next tick writes, without
    computing it again; a physics step, another target array or a second tick recompute."""
    model, data, robot = kit
    twin, twin_data = _twin(model, data)
    batch = robot.joint_target_batch(NAMES)
    real, calls = JointTargetBatch._limited, []
    monkeypatch.setattr(JointTargetBatch, "_limited", lambda *a: calls.append(a[3]) or real(*a))
    rng = np.random.default_rng(4)
    for case in ("kept", "stepped", "other array", "second tick"):
        commands = _random_commands(robot, rng)
        vector = np.concatenate([commands[n] for n in NAMES])
        end = batch.preview(data, vector, 1, keep=True)
        if case == "stepped":
            mujoco.mj_step(model, data)
            mujoco.mj_copyData(twin_data, model, data)
        if case == "other array":
            vector = vector.copy()
        robot.update_control(JointTargets(batch, vector))
        twin.update_control({n: commands[n] for n in NAMES})
        calls.clear()
        robot.compute_control()
        ours = list(calls)
        twin.compute_control()
        assert np.array_equal(data.ctrl, twin_data.ctrl), case  # the same controls
        calls[:] = ours
        if case in ("kept", "second tick"):
            assert np.array_equal(data.ctrl[batch._sel], end) and calls == [], case
        else:
            assert calls == [1], case  # computed for this tick
        if case == "second tick":
            calls.clear()
            robot.compute_control()
            assert calls == [1]  # a kept preview serves one tick only
        mujoco.mj_copyData(twin_data, model, data)
    # previews without keep, or over several ticks, are never reused
    for ticks, keep in ((1, False), (3, True)):
        vector = np.concatenate(list(_random_commands(robot, rng).values()))
        batch.preview(data, vector, ticks, keep=keep)
        batch.set_vector(vector)
        calls.clear()
        batch.apply(data)
        assert calls == [1]


def test_joint_targets_are_checked(kit):
    _, _, robot = kit
    batch = robot.joint_target_batch(("left_arm", "left_gripper"))
    with pytest.raises(UserError, match="expected 7 values, got 6"):
        batch.commands(np.zeros(6))
    with pytest.raises(UserError, match="NaN or inf"):
        batch.commands(np.array([0, 0, 0, np.nan, 0, 0, 0.02]))


def test_changed_joint_targets_are_read_entry_by_entry(kit):
    model, data, robot = kit
    twin, twin_data = _twin(model, data)
    batch = robot.joint_target_batch(NAMES)
    targets = batch.commands(np.zeros(14))
    targets["right_arm"] = np.full(6, 0.3)  # no longer a view of the vector
    assert targets.vector is None
    robot.update_control(targets)
    twin.update_control(
        {**{n: np.zeros(len(targets[n])) for n in NAMES}, "right_arm": np.full(6, 0.3)}
    )
    robot.compute_control()
    twin.compute_control()
    assert np.array_equal(data.ctrl, twin_data.ctrl)


def test_joint_targets_of_an_outdated_batch_follow_the_new_limits(kit):
    _, data, robot = kit
    batch = robot.joint_target_batch(("left_arm", "left_gripper"))
    arm = robot.view.get_move_group("left_arm")
    arm.set_velocity_limits(np.full(6, 0.5))  # the batch no longer fits
    before = arm.get_ctrl(data)
    robot.update_control(batch.commands(np.concatenate([before + 1.0, [0.02]])))
    robot.compute_control()
    assert np.allclose(arm.get_ctrl(data) - before, 0.5 * 0.02)
    assert robot.joint_target_batch(("left_arm", "left_gripper")) is not batch  # rebuilt


def test_joint_targets_with_another_command_pending(kit):
    model, data, robot = kit
    twin, twin_data = _twin(model, data)
    pending = {"right_arm": np.full(6, 0.2)}
    robot.update_control(pending)
    twin.update_control(pending)
    batch = robot.joint_target_batch(("left_arm", "left_gripper"))
    robot.update_control(batch.commands(np.full(7, 0.01)))
    twin.update_control({"left_arm": np.full(6, 0.01), "left_gripper": np.array([0.01])})
    for _ in range(3):
        robot.compute_control()
        twin.compute_control()
        assert np.array_equal(data.ctrl, twin_data.ctrl)
    assert robot._commands.keys() == {"right_arm", "left_arm", "left_gripper"}


def test_no_batch_for_a_subclassed_controller(kit):
    _, _, robot = kit

    class Doubled(JointPosController):
        def _target(self, data, cmd):
            return 2.0 * cmd

    robot.controllers["left_arm"] = Doubled(robot.view.get_move_group("left_arm"), robot.model)
    assert robot.joint_target_batch(("left_arm", "left_gripper")) is None
    assert robot.joint_target_batch(("right_arm", "right_gripper")) is not None
    with pytest.raises(UserError, match="controlled move group"):
        robot.joint_target_batch(("left_arm", "middle_arm"))
