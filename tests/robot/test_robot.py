"""Robot: command validation, reset/hold, and name errors that list the valid names."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import (
    MoveGroupSpec,
    RobotConfig,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.controllers import EEDeltaController
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.scene import Scene

ASSETS = Path(ASSETS_DIR)
KIT_JOINT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"
KIT_MOCAP = ASSETS / "stationary_ai/trossen_ai_scene.xml"
KIT_GROUPS = ["left_arm", "left_gripper", "right_arm", "right_gripper"]


@pytest.fixture
def kit():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    robot = Robot(model, stationary_ai_joint_config())
    robot.reset(data)
    return model, data, robot


def test_update_control_unknown_group_lists_valid_names(kit):
    _, _, robot = kit
    with pytest.raises(UserError) as err:
        robot.update_control({"left_hand": np.zeros(6)})
    msg = str(err.value)
    assert "unknown controlled move group 'left_hand'" in msg
    for name in KIT_GROUPS:
        assert name in msg
    # bases are move groups but have no controller
    with pytest.raises(UserError, match="controlled move group 'left_base'"):
        robot.update_control({"left_base": []})


@pytest.mark.parametrize(
    ("group", "command", "match"),
    [
        ("left_arm", np.zeros(5), "expected 6 values, got 5"),
        ("left_arm", np.zeros(7), "expected 6 values, got 7"),
        ("left_arm", np.zeros((2, 6)), "expected 6 values, got 12"),
        ("left_gripper", [0.01, 0.01], "expected 1 values, got 2"),
        ("left_arm", [0, 0, np.nan, 0, 0, 0], "NaN or inf"),
        ("right_gripper", [np.inf], "NaN or inf"),
    ],
)
def test_update_control_rejects_bad_commands(kit, group, command, match):
    _, data, robot = kit
    ctrl_before = data.ctrl.copy()
    with pytest.raises(UserError, match=match):
        robot.update_control({group: command})
    robot.compute_control(data)
    np.testing.assert_array_equal(data.ctrl, ctrl_before)  # nothing was stored


def test_update_control_accepts_lists_and_compute_returns_by_group(kit):
    model, data, _ = kit
    robot = Robot(model, stationary_ai_joint_config().with_rate_limit(False))  # one-tick jumps
    robot.reset(data)
    target = [0.1, 0.5, 0.4, 0.0, 0.1, 0.0]
    robot.update_control({"right_arm": target, "right_gripper": [0.02]})
    out = robot.compute_control(data)
    assert set(out) == {"right_arm", "right_gripper"}
    np.testing.assert_allclose(data.ctrl[7:13], target)
    np.testing.assert_allclose(data.ctrl[13], 0.02)


def test_apply_control_writes_what_compute_control_writes():
    """The stepping loop's apply_control is compute_control without the returned dict: the
    same controls, tick by tick, for batched, per-group and relative commands."""
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    robots, datas = [], []
    for _ in range(2):
        data = mujoco.MjData(model)
        config = stationary_ai_joint_config().with_command_modes(right_arm="joint_rel_position")
        robot = Robot(model, config, ctrl_dt=0.02, data=data)
        robot.reset()
        robots.append(robot)
        datas.append(data)
    rng = np.random.default_rng(0)
    for _ in range(6):
        commands = {
            "left_arm": rng.uniform(-0.5, 0.5, 6),
            "left_gripper": rng.uniform(0.0, 0.04, 1),
            "right_arm": rng.uniform(-0.05, 0.05, 6),  # relative: held until reached
        }
        for robot in robots:
            robot.update_control(commands)
        for _ in range(3):
            out = robots[0].compute_control()
            assert robots[1].apply_control() is None
            assert {"left_arm", "left_gripper"} <= set(out) <= {*commands}
            assert np.array_equal(datas[0].ctrl, datas[1].ctrl)


def test_reset_puts_init_qpos_and_holds(kit):
    model, data, robot = kit
    np.testing.assert_allclose(data.qpos[:16], START_ARM_POSE)
    np.testing.assert_array_equal(data.qvel[:16], 0.0)
    # ctrl holds the initial pose: arm joints and the actuated finger
    expected = [*START_ARM_POSE[0:6], START_ARM_POSE[7], *START_ARM_POSE[8:14], START_ARM_POSE[15]]
    np.testing.assert_allclose(data.ctrl, expected)
    # a reset forgets stored commands
    robot.update_control({"left_arm": np.ones(6) * 0.3})
    robot.reset(data)
    assert robot.compute_control(data) == {}


def test_reset_mocap_targets_follow_the_tool_frame():
    model = mujoco.MjModel.from_xml_path(str(KIT_MOCAP))
    data = mujoco.MjData(model)
    robot = Robot(model, stationary_ai_mocap_config())
    data.mocap_pos[:] = 0.0  # garbage before reset
    robot.reset(data)
    for side, mocap_id in (("left", 0), ("right", 1)):
        frame = robot.view.get_move_group(f"{side}_arm").get_frame_pose(data)
        np.testing.assert_allclose(data.mocap_pos[mocap_id], frame[:3], atol=1e-12)
        np.testing.assert_allclose(np.abs(data.mocap_quat[mocap_id] @ frame[3:]), 1.0, atol=1e-12)


def test_hold_keeps_the_current_state(kit):
    model, data, robot = kit
    data.qpos[8:14] = [0.2, 0.4, 0.3, 0.1, 0.0, -0.1]
    mujoco.mj_kinematics(model, data)
    robot.update_control({"right_arm": np.zeros(6)})
    robot.hold(data)
    np.testing.assert_allclose(data.ctrl[7:13], [0.2, 0.4, 0.3, 0.1, 0.0, -0.1])
    assert robot.compute_control(data) == {}  # hold clears pending commands


def test_unknown_command_mode_in_config():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    config = stationary_ai_joint_config()
    bad = RobotConfig(
        config.name, config.groups, config.init_qpos, {**config.command_mode, "left_arm": "torque"}
    )
    with pytest.raises(UserError, match="unknown command mode 'torque'.*joint_position"):
        Robot(model, bad)


def test_unknown_joint_name_lists_valid_joints():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    config = RobotConfig(
        "x",
        {
            "arm": MoveGroupSpec(
                "arm", ("left/joint_7",), ("left/joint_0",), frame_site="left/ee_site"
            )
        },
    )
    with pytest.raises(UserError) as err:
        Robot(model, config)
    msg = str(err.value)
    assert "unknown joint 'left/joint_7'" in msg
    assert "left/joint_0" in msg and "right/left_carriage_joint" in msg


def test_unknown_site_name_lists_valid_sites():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    config = RobotConfig(
        "x",
        {"arm": MoveGroupSpec("arm", ("left/joint_0",), ("left/joint_0",), frame_site="left/tool")},
    )
    with pytest.raises(UserError, match=r"unknown site 'left/tool'; valid sites: left/ee_site"):
        Robot(model, config)


def test_unknown_camera_name_lists_valid_cameras():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    with pytest.raises(UserError) as err:
        CameraSet(model, ["cam_top"], 24, 32)
    msg = str(err.value)
    assert "unknown camera 'cam_top'" in msg
    for cam in ("cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"):
        assert cam in msg


def test_config_for_the_wrong_model_fails_clearly():
    """A kit config on the single-arm model names the missing joint and the valid ones."""
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    with pytest.raises(UserError, match=r"unknown (body|joint) 'left/.*valid"):
        Robot(model, stationary_ai_joint_config())
    Robot(model, wxai_config())  # the right config builds


def test_ctrl_dt_defaults_to_the_timestep_and_reaches_the_controllers():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    robot = Robot(model, stationary_ai_joint_config())
    assert robot.ctrl_dt == model.opt.timestep
    robot = Robot(model, stationary_ai_joint_config(), ctrl_dt=0.02)
    assert {c.ctrl_dt for c in robot.controllers.values()} == {0.02}
    np.testing.assert_allclose(
        robot.controllers["left_arm"].max_step, [0.0675] * 3 + [0.14] * 3
    )  # rad per tick
    np.testing.assert_allclose(robot.controllers["left_gripper"].max_step, [0.00175])  # m
    scene = Scene(KIT_JOINT, robots={"kit": stationary_ai_joint_config()}, ctrl_dt=0.02)
    assert scene.robots["kit"].ctrl_dt == 0.02
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(UserError, match="ctrl_dt must be a positive"):
            Robot(model, stationary_ai_joint_config(), ctrl_dt=bad)


def test_a_controller_swapped_in_without_ctrl_dt_takes_the_robots():
    """As a sampler does when it swaps in a 6-D ee_delta controller after construction."""
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    robot = Robot(model, stationary_ai_joint_config(), ctrl_dt=0.02)
    robot.reset(data)
    arm = robot.view.get_move_group("left_arm")
    robot.controllers["left_arm"] = EEDeltaController(arm, model, rotation=True)
    robot.update_control({"left_arm": [0.05, 0, -0.05, 0, 0, 0]})
    before = arm.get_ctrl(data)
    moved = robot.compute_control(data)["left_arm"] - before
    assert robot.controllers["left_arm"].ctrl_dt == 0.02
    assert np.max(np.abs(moved) / (arm.velocity_limits * 0.02)) == pytest.approx(1.0)


def test_rate_limit_starts_from_the_held_state(kit):
    """No bookkeeping: after hold (or reset) the limit counts from the joints held."""
    model, data, robot = kit
    q = [0.2, 0.4, 0.3, 0.1, 0.0, -0.1]
    data.qpos[8:14] = q
    mujoco.mj_kinematics(model, data)
    robot.hold(data)
    robot.update_control({"right_arm": [2.0, 2.0, 2.0, 1.5, 1.5, 3.0]})
    out = robot.compute_control(data)["right_arm"]
    step = np.array([3.375] * 3 + [7.0] * 3) * model.opt.timestep
    np.testing.assert_allclose(out, np.array(q) + step)


def test_hold_and_reset_drop_a_pending_relative_target():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    config = stationary_ai_joint_config().with_command_modes(left_arm="joint_rel_position")
    robot = Robot(model, config, ctrl_dt=0.02)
    for stop in (robot.hold, robot.reset):
        robot.reset(data)
        robot.update_control({"left_arm": np.full(6, 0.5)})  # several ticks away
        assert "left_arm" in robot.compute_control(data)
        assert "left_arm" in robot.compute_control(data)  # still on its way
        mujoco.mj_kinematics(model, data)
        stop(data)
        assert robot.compute_control(data) == {}


# -- the documented surface: robot_view, bound calls, kinematics, set_world_pose ------------

WXAI = ASSETS / "wxai/wxai_follower.xml"


def wxai_mocap_base_model() -> mujoco.MjModel:
    """The wxai with its base_link made a mocap body (teleportable)."""
    spec = mujoco.MjSpec.from_file(str(WXAI))
    spec.body("base_link").mocap = True
    return spec.compile()


def test_bound_robot_works_without_passing_data():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    robot = Robot(data, stationary_ai_joint_config().with_rate_limit(False))
    assert robot.robot_view is robot.view and robot.robot_view.is_bound
    assert robot.model is model
    robot.reset()
    np.testing.assert_allclose(data.qpos[:16], START_ARM_POSE)
    target = [0.1, 0.5, 0.4, 0.0, 0.1, 0.0]
    robot.update_control({"right_arm": target})
    out = robot.compute_control()
    np.testing.assert_allclose(out["right_arm"], target)
    np.testing.assert_allclose(robot.robot_view.get_move_group("right_arm").ctrl, target)
    robot.hold()
    assert robot.compute_control() == {}
    same = Robot(model, stationary_ai_joint_config(), data=data)  # the keyword form
    assert same.robot_view.data is data


def test_unbound_robot_says_how_to_bind():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    robot = Robot(model, stationary_ai_joint_config())
    with pytest.raises(UserError, match="not bound to an MjData"):
        robot.compute_control()
    data = mujoco.MjData(model)
    robot.bind(data)
    robot.reset()
    np.testing.assert_allclose(data.qpos[:16], START_ARM_POSE)


def test_scene_robots_are_bound_to_the_scene_data():
    scene = Scene(KIT_JOINT, robots={"kit": stationary_ai_joint_config()}, ctrl_dt=0.02)
    scene.reset()
    view = scene.robots["kit"].robot_view
    assert view.data is scene.data
    np.testing.assert_allclose(view.get_move_group("left_arm").joint_pos, START_ARM_POSE[:6])


def test_kinematics_and_parallel_kinematics():
    from trossen_arm_mujoco.robot import ParallelKinematics, RobotKinematics

    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    data = mujoco.MjData(model)
    robot = Robot(data, stationary_ai_joint_config())
    robot.reset()
    assert isinstance(robot.kinematics, RobotKinematics)
    assert robot.kinematics is robot.kinematics  # built once
    assert robot.kinematics.reference is robot.robot_view
    parallel = robot.parallel_kinematics
    assert isinstance(parallel, ParallelKinematics)
    assert parallel.move_group_id == "left_arm" and parallel.kinematics is robot.kinematics
    right = robot.get_parallel_kinematics("right_arm")
    assert right.move_group_id == "right_arm" and right is robot.get_parallel_kinematics(
        "right_arm"
    )
    mujoco.mj_forward(model, data)
    fk = robot.kinematics.fk()  # the live state
    for name, group in robot.robot_view.move_groups.items():
        np.testing.assert_allclose(fk[name], group.leaf_frame_to_world, atol=1e-12)


def test_set_world_pose_on_an_immobile_base_fails_clearly():
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    data = mujoco.MjData(model)
    robot = Robot(data, wxai_config())
    robot.reset()
    qpos = data.qpos.copy()
    with pytest.raises(UserError, match="'base' is an immobile base .*cannot be set") as err:
        robot.set_world_pose(np.eye(4))
    assert "\n" not in str(err.value)
    np.testing.assert_array_equal(data.qpos, qpos)
    np.testing.assert_allclose(robot.get_world_pose(), np.eye(4), atol=1e-12)


def test_set_world_pose_teleports_a_mocap_base():
    model = wxai_mocap_base_model()
    data = mujoco.MjData(model)
    robot = Robot(data, wxai_config().with_base_kind("mocap_base"))
    robot.reset()
    arm = robot.robot_view.get_move_group("arm")
    in_robot = arm.leaf_frame_to_robot
    pose = np.array([0.3, -0.1, 0.2, np.cos(0.4), 0.0, 0.0, np.sin(0.4)])  # yaw 0.8 rad
    robot.set_world_pose(pose)
    world = robot.get_world_pose()
    np.testing.assert_allclose(world[:3, 3], pose[:3], atol=1e-12)
    np.testing.assert_allclose(arm.leaf_frame_to_robot, in_robot, atol=1e-12)  # came along
    np.testing.assert_allclose(arm.leaf_frame_to_world, world @ in_robot, atol=1e-12)
    # FK with the base where it is now agrees with the teleported arm
    np.testing.assert_allclose(robot.kinematics.fk()["arm"], arm.leaf_frame_to_world, atol=1e-12)
    with pytest.raises(UserError, match="world pose: expected a 4x4 transform or 7 values"):
        robot.set_world_pose([0.0, 0.0, 0.0])


def test_set_world_pose_writes_a_free_joint_base(toy):
    model = toy.model("free")
    data = mujoco.MjData(model)
    robot = Robot(data, toy.config("free"))
    robot.reset()
    target = np.eye(4)
    target[:3, 3] = [1.0, 2.0, 0.5]
    robot.set_world_pose(target)
    np.testing.assert_allclose(data.qpos[:7], [1.0, 2.0, 0.5, 1, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(robot.get_world_pose(), target, atol=1e-12)
    mujoco.mj_kinematics(model, data)
    base = model.body("base").id
    np.testing.assert_allclose(data.xpos[base], [1.0, 2.0, 0.5], atol=1e-12)


def test_with_base_kind():
    config = wxai_config().with_base_kind("mocap_base")
    assert config.groups["base"].kind == "mocap_base"
    assert wxai_config().groups["base"].kind == "base"  # the original is unchanged
    with pytest.raises(UserError, match="unknown base kind 'wheels'"):
        wxai_config().with_base_kind("wheels")
    model = mujoco.MjModel.from_xml_path(str(WXAI))  # base_link is not mocap here
    with pytest.raises(UserError, match="'base_link' is not a mocap body"):
        Robot(model, config)
