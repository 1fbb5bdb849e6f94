"""Robot configs: every config builds its view on its model; modes, init poses, helpers."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR, GRIPPER_OPEN, START_ARM_POSE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.arm_groups import ArmMoveGroup, MocapArmGroup
from trossen_arm_mujoco.robot.base_group import ImmobileRobotBaseGroup
from trossen_arm_mujoco.robot.configs import (
    JOINT_VELOCITY_LIMITS,
    MoveGroupSpec,
    qpos16_to_dict,
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.gripper_group import GripperGroup

ASSETS = Path(ASSETS_DIR)
CONFIG_MODELS = [
    (wxai_config, "wxai/wxai_follower.xml"),
    (stationary_ai_joint_config, "stationary_ai/trossen_ai_scene_joint.xml"),
    (stationary_ai_mocap_config, "stationary_ai/trossen_ai_scene.xml"),
]


@pytest.mark.parametrize(("make", "xml"), CONFIG_MODELS, ids=lambda v: getattr(v, "__name__", v))
def test_every_config_builds_on_its_model(make, xml):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / xml))
    config = make()
    view = config.build_view(model)
    assert list(view.move_groups) == list(config.groups)
    assert set(config.command_mode) <= set(config.groups)
    assert set(config.init_qpos) <= set(config.groups)
    for name, q in config.init_qpos.items():
        group = view.get_move_group(name)
        assert len(q) == group.n_joints
        assert np.all(np.asarray(q) >= group.joint_range[:, 0])
        assert np.all(np.asarray(q) <= group.joint_range[:, 1])


def test_wxai_config():
    config = wxai_config()
    assert config.command_mode == {"arm": "joint_position", "gripper": "joint_position"}
    assert wxai_config("ee_delta").command_mode["arm"] == "ee_delta"
    np.testing.assert_allclose(config.init_qpos["arm"], START_ARM_POSE[:6])
    np.testing.assert_allclose(config.init_qpos["gripper"], [GRIPPER_OPEN, GRIPPER_OPEN])
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    view = config.build_view(model)
    assert isinstance(view.get_move_group("arm"), ArmMoveGroup)
    assert isinstance(view.get_move_group("gripper"), GripperGroup)
    assert isinstance(view.get_move_group("base"), ImmobileRobotBaseGroup)
    assert view.get_move_group("arm").frame_site_name == "ee_site"


def test_stationary_configs():
    joint, mocap = stationary_ai_joint_config(), stationary_ai_mocap_config()
    groups = {f"{s}_{g}" for s in ("left", "right") for g in ("base", "arm", "gripper")}
    assert set(joint.groups) == set(mocap.groups) == groups
    assert joint.command_mode["left_arm"] == "joint_position"
    assert mocap.command_mode["right_arm"] == "ee_pose"
    assert mocap.command_mode["right_gripper"] == "joint_position"
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "stationary_ai/trossen_ai_scene.xml"))
    view = mocap.build_view(model)
    assert isinstance(view.get_move_group("left_arm"), MocapArmGroup)
    assert view.get_move_group("left_arm").frame_site_name == "left/ee_site"
    assert view.get_move_group("right_arm").mocap_id == 1


def test_with_command_modes():
    config = stationary_ai_joint_config()
    new = config.with_command_modes(left_arm="ee_delta")
    assert new.command_mode["left_arm"] == "ee_delta"
    assert config.command_mode["left_arm"] == "joint_position"  # the original is unchanged
    with pytest.raises(UserError, match="unknown move group 'middle_arm'.*left_arm"):
        config.with_command_modes(middle_arm="ee_pose")


def test_unknown_group_kind():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    with pytest.raises(UserError, match="unknown move group kind 'wheel'.*mocap_arm"):
        MoveGroupSpec("wheel").build(model, "x")


def test_qpos16_to_dict():
    q = np.arange(16.0)
    d = qpos16_to_dict(q)
    np.testing.assert_array_equal(d["left_arm"], q[0:6])
    np.testing.assert_array_equal(d["left_gripper"], q[6:8])
    np.testing.assert_array_equal(d["right_arm"], q[8:14])
    np.testing.assert_array_equal(d["right_gripper"], q[14:16])


URDF_ARM = (3.375, 3.375, 3.375, 7.0, 7.0, 7.0)  # rad/s
URDF_FINGER = (0.0875,)  # m/s


def test_joint_velocity_limits_table_is_the_urdf():
    assert JOINT_VELOCITY_LIMITS == {
        **{f"joint_{i}": v for i, v in enumerate(URDF_ARM)},
        "right_carriage_joint": 0.0875,
        "left_carriage_joint": 0.0875,
    }


@pytest.mark.parametrize(("make", "xml"), CONFIG_MODELS, ids=lambda v: getattr(v, "__name__", v))
def test_default_configs_carry_the_urdf_limits(make, xml):
    config = make()
    view = config.build_view(mujoco.MjModel.from_xml_path(str(ASSETS / xml)))
    for name, spec in config.groups.items():
        group = view.get_move_group(name)
        if spec.kind == "arm":
            assert spec.velocity_limits == URDF_ARM and spec.rate_limit
            np.testing.assert_array_equal(group.velocity_limits, URDF_ARM)
        elif spec.kind == "gripper":
            assert spec.velocity_limits == URDF_FINGER and spec.rate_limit
            np.testing.assert_array_equal(group.velocity_limits, URDF_FINGER)
        else:  # bases and mocap arms (driven by the weld) take none
            assert spec.velocity_limits is None and group.velocity_limits is None


def test_with_velocity_limits_and_with_rate_limit():
    config = stationary_ai_joint_config()
    slow = config.with_velocity_limits(left_gripper=[0.05], right_arm=np.full(6, 1.0))
    assert slow.groups["left_gripper"].velocity_limits == (0.05,)
    assert slow.groups["right_arm"].velocity_limits == (1.0,) * 6
    assert config.groups["right_arm"].velocity_limits == URDF_ARM  # the original is unchanged
    off = config.with_rate_limit(False)
    assert not any(s.rate_limit for s in off.groups.values())
    assert off.groups["left_arm"].velocity_limits == URDF_ARM  # kept on record
    assert off.groups["left_arm"].enforced_velocity_limits is None
    one = off.with_rate_limit(True, "left_arm")
    assert one.groups["left_arm"].enforced_velocity_limits == URDF_ARM
    assert one.groups["right_arm"].enforced_velocity_limits is None
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"))
    view = one.build_view(model)
    assert view.get_move_group("right_gripper").velocity_limits is None
    np.testing.assert_array_equal(view.get_move_group("left_arm").velocity_limits, URDF_ARM)
    with pytest.raises(UserError, match="unknown move group 'arm'.*left_arm"):
        config.with_velocity_limits(arm=[1.0] * 6)
    with pytest.raises(UserError, match="'left_base' has no velocity limits"):
        config.with_rate_limit(True, "left_base")


@pytest.mark.parametrize(
    ("make_bad", "match"),
    [
        (lambda: wxai_config().with_velocity_limits(arm=[3.0, 3.0]), r"arm: expected 6 velocity"),
        (lambda: wxai_config().with_velocity_limits(gripper=[0.1, 0.1]), r"expected 1 velocity"),
        (lambda: wxai_config().with_velocity_limits(arm=[1, 1, 1, 1, 1, -1]), "positive"),
        (lambda: wxai_config().with_velocity_limits(base=[1.0]), "takes no velocity limits"),
        (
            lambda: MoveGroupSpec("arm", ("a", "b"), ("a", "b"), velocity_limits=(1.0,)),
            r"expected 2 velocity limits",
        ),
        (
            lambda: MoveGroupSpec("mocap_arm", ("a",), velocity_limits=(1.0,)),
            "'mocap_arm' move group takes no velocity limits",
        ),
    ],
)
def test_bad_velocity_limits_fail_in_one_line(make_bad, match):
    with pytest.raises(UserError, match=match) as err:
        make_bad()
    assert "\n" not in str(err.value)


def test_group_checks_its_velocity_limits():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    view = wxai_config().build_view(model)
    with pytest.raises(UserError, match=r"^arm: expected 6 velocity limits .*got 7$"):
        view.get_move_group("arm").set_velocity_limits(np.ones(7))
    with pytest.raises(UserError, match="velocity limits apply to joint-actuated"):
        view.get_move_group("base").set_velocity_limits([1.0])
    view.get_move_group("arm").set_velocity_limits(None)
    assert view.get_move_group("arm").velocity_limits is None
