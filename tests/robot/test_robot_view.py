"""RobotView: group lookup, qpos/ctrl dicts, and tool-frame Jacobians masked by move group."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import (
    stationary_ai_joint_config,
    stationary_ai_mocap_config,
    wxai_config,
)
from trossen_arm_mujoco.robot.kinematics import orientation_error

ASSETS = Path(ASSETS_DIR)
CASES = {  # name: (xml, config, frame groups)
    "wxai": (ASSETS / "wxai/wxai_follower.xml", wxai_config, ["arm"]),
    "kit_joint": (
        ASSETS / "stationary_ai/trossen_ai_scene_joint.xml",
        stationary_ai_joint_config,
        ["left_arm", "right_arm"],
    ),
    "kit_mocap": (
        ASSETS / "stationary_ai/trossen_ai_scene.xml",
        stationary_ai_mocap_config,
        ["left_arm", "right_arm"],
    ),
}
FRAME_CASES = [(case, g) for case, (_, _, groups) in CASES.items() for g in groups]


def make_view(case: str):
    xml, config, _ = CASES[case]
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    return model, data, config().build_view(model)


def set_test_pose(model, data, view) -> None:
    """A generic pose (away from singularities) for every arm group."""
    q = np.array([0.4, 0.7, 0.5, -0.3, 0.4, 0.9])
    for name, group in view.move_groups.items():
        if name.endswith("arm"):
            group.set_qpos(data, q)
            q = q * -1 + np.array([0, 1.4, 1.0, 0, 0, 0])  # different pose for the second arm
    mujoco.mj_forward(model, data)


def frame_pose(model, data, view, group: str) -> np.ndarray:
    mujoco.mj_kinematics(model, data)
    return view.get_move_group(group).get_frame_pose(data)


@pytest.mark.parametrize(("case", "frame"), FRAME_CASES)
def test_jacobian_matches_finite_differences(case, frame):
    model, data, view = make_view(case)
    set_test_pose(model, data, view)
    jac = view.get_jacobian(data, frame)  # all groups
    dofs = view.dof_indices()
    assert jac.shape == (6, len(dofs))
    qpos0 = data.qpos.copy()
    eps = 1e-6
    for col, dof in enumerate(dofs):
        jnt = int(model.dof_jntid[dof])
        adr = int(model.jnt_qposadr[jnt])
        data.qpos[:] = qpos0
        data.qpos[adr] += eps
        plus = frame_pose(model, data, view, frame)
        data.qpos[:] = qpos0
        data.qpos[adr] -= eps
        minus = frame_pose(model, data, view, frame)
        lin = (plus[:3] - minus[:3]) / (2 * eps)
        ang = orientation_error(plus[3:], minus[3:]) / (2 * eps)
        np.testing.assert_allclose(jac[:3, col], lin, atol=1e-6, err_msg=f"dof {dof} linear")
        np.testing.assert_allclose(jac[3:, col], ang, atol=1e-6, err_msg=f"dof {dof} angular")


@pytest.mark.parametrize(("case", "frame"), FRAME_CASES)
def test_jacobian_mask_selects_group_columns(case, frame):
    model, data, view = make_view(case)
    set_test_pose(model, data, view)
    full = np.zeros((6, model.nv))
    mujoco.mj_jacSite(model, data, full[:3], full[3:], view.get_move_group(frame).frame_site_id)
    for name, group in view.move_groups.items():
        masked = view.get_jacobian(data, frame, [name])
        assert masked.shape == (6, group.n_joints)
        np.testing.assert_array_equal(masked, full[:, group.dof_idx])
    # the frame's own arm moves it; every other group's columns are zero, except the
    # gripper of the same arm, which does not move the tool frame either
    own = view.get_jacobian(data, frame, [frame])
    assert np.linalg.matrix_rank(own) == 6
    others = [n for n in view.move_groups if n != frame]
    np.testing.assert_array_equal(view.get_jacobian(data, frame, others), 0.0)
    # order of the mask is the order of the columns
    two = [frame, others[-1]]
    np.testing.assert_array_equal(
        view.get_jacobian(data, frame, two), full[:, view.dof_indices(two)]
    )


def test_jacobian_needs_a_frame_group():
    _, data, view = make_view("wxai")
    with pytest.raises(UserError, match="no tool frame"):
        view.get_jacobian(data, "gripper")
    with pytest.raises(UserError, match="valid move groups: arm, base, gripper"):
        view.get_jacobian(data, "hand")


def test_unknown_group_lists_valid_names():
    _, _, view = make_view("kit_joint")
    with pytest.raises(UserError) as err:
        view.get_move_group("left")
    msg = str(err.value)
    for name in ("left_arm", "left_gripper", "right_arm", "right_gripper", "left_base"):
        assert name in msg


def test_qpos_dict_roundtrip_and_indices():
    model, data, view = make_view("kit_joint")
    qpos = view.get_qpos_dict(data)
    assert set(qpos) == {"left_arm", "left_gripper", "right_arm", "right_gripper"}  # no bases
    new = {
        "left_arm": np.asarray(START_ARM_POSE[0:6]),
        "left_gripper": np.array([0.02, 0.02]),
        "right_arm": np.asarray(START_ARM_POSE[8:14]) + 0.1,
        "right_gripper": np.array([0.01, 0.01]),
    }
    view.set_qpos_dict(data, new)
    got = view.get_qpos_dict(data)
    for name, value in new.items():
        np.testing.assert_array_equal(got[name], value)
    layout = ["left_arm", "left_gripper", "right_arm", "right_gripper"]
    np.testing.assert_array_equal(view.qpos_indices(layout), np.arange(16))
    np.testing.assert_array_equal(view.dof_indices(layout), np.arange(16))
    assert view.qpos_indices([]).size == 0
    assert set(view.get_qvel_dict(data)) == set(qpos)


def test_ctrl_dicts_kit_joint():
    model, data, view = make_view("kit_joint")
    view.set_qpos_dict(
        data, {"left_arm": np.asarray(START_ARM_POSE[0:6]), "left_gripper": [0.03, 0.03]}
    )
    noop = view.get_noop_ctrl_dict(data)
    assert {k: v.shape for k, v in noop.items()} == {
        "left_arm": (6,),
        "left_gripper": (1,),
        "right_arm": (6,),
        "right_gripper": (1,),
    }
    np.testing.assert_array_equal(noop["left_arm"], START_ARM_POSE[0:6])
    np.testing.assert_array_equal(noop["left_gripper"], [0.03])
    for name, ctrl in noop.items():
        view.get_move_group(name).set_ctrl(data, ctrl)
    got = view.get_ctrl_dict(data)
    for name in noop:
        np.testing.assert_allclose(got[name], noop[name])


def test_ctrl_dicts_kit_mocap():
    model, data, view = make_view("kit_mocap")
    mujoco.mj_forward(model, data)
    ctrl = view.get_ctrl_dict(data)
    assert ctrl["left_arm"].shape == (7,) and ctrl["right_arm"].shape == (7,)
    np.testing.assert_array_equal(ctrl["left_arm"][:3], data.mocap_pos[0])
    np.testing.assert_array_equal(ctrl["right_arm"][3:], data.mocap_quat[1])


# -- the data-bound form: RobotView(data, groups) ------------------------------------------


def bound_view(case: str):
    xml, config, _ = CASES[case]
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    view = config().build_view(data)
    return model, data, view


def test_bound_view_ids_and_groups():
    model, data, view = bound_view("kit_joint")
    assert view.is_bound and view.data is data
    assert view.move_group_ids() == list(stationary_ai_joint_config().groups)
    arm = view.get_move_group("left_arm")
    assert arm is view.get_move_group("left_arm") and arm.data is data
    assert all(g.is_bound for g in view.move_groups.values())
    assert view.base_group_ids() == ["left_base", "right_base"]
    assert view.base is view.get_move_group("left_base")
    assert arm.robot_base_group is view.get_move_group("left_base")
    assert view.get_move_group("right_gripper").robot_base_group is view.get_move_group(
        "right_base"
    )
    with pytest.raises(UserError, match="unknown move group 'left'.*left_arm"):
        view.get_move_group("left")


def test_view_built_from_a_dict_of_groups(toy):
    from trossen_arm_mujoco.robot import GripperGroup, RobotView
    from trossen_arm_mujoco.robot.arm_groups import ArmMoveGroup

    model = toy.model()
    data = mujoco.MjData(model)
    groups = {
        "arm": ArmMoveGroup(model, "arm", ["j1", "j2", "j3"], ["a1", "a2", "a3"], "tool"),
        "gripper": GripperGroup(model, "gripper", ["fa", "fb"], "grip"),
    }
    view = RobotView(data, groups)
    assert groups["arm"].data is data  # binding the view binds its groups
    view.set_qpos_dict({"arm": [0.1, 0.2, 0.03], "gripper": [0.01, 0.01]})
    np.testing.assert_array_equal(data.qpos[:5], [0.1, 0.2, 0.03, 0.01, 0.01])
    with pytest.raises(UserError, match="robot view has no base group"):
        view.base  # noqa: B018


def test_bound_qpos_and_ctrl_dicts():
    model, data, view = bound_view("kit_joint")
    new = {"left_arm": np.asarray(START_ARM_POSE[0:6]), "right_gripper": np.array([0.01, 0.01])}
    view.set_qpos_dict(new)
    got = view.get_qpos_dict(["left_arm", "right_gripper"])
    assert list(got) == ["left_arm", "right_gripper"]
    for name, value in new.items():
        np.testing.assert_array_equal(got[name], value)
    assert set(view.get_qpos_dict()) == {"left_arm", "left_gripper", "right_arm", "right_gripper"}
    assert view.get_qpos_dict(["left_base"])["left_base"].shape == (0,)
    noop = view.get_noop_ctrl_dict()
    assert set(noop) == {"left_arm", "left_gripper", "right_arm", "right_gripper"}
    np.testing.assert_array_equal(noop["left_arm"], START_ARM_POSE[0:6])
    np.testing.assert_array_equal(
        view.get_noop_ctrl_dict(["right_gripper"])["right_gripper"], [0.01]
    )
    for name, ctrl in noop.items():
        view.get_move_group(name).ctrl = ctrl
    ctrl = view.get_ctrl_dict(["left_arm"])
    assert list(ctrl) == ["left_arm"]
    np.testing.assert_array_equal(ctrl["left_arm"], START_ARM_POSE[0:6])
    assert set(view.get_qvel_dict()) == set(view.get_qpos_dict())
    # the same answers in the earlier data-explicit form
    for name, value in view.get_qpos_dict(data).items():
        np.testing.assert_array_equal(value, view.get_qpos_dict()[name])
    with pytest.raises(UserError, match="unknown move group 'arm'"):
        view.get_ctrl_dict(["arm"])
    with pytest.raises(UserError, match="expected a list of move group ids"):
        view.get_qpos_dict("left_arm")


def test_unbound_view_says_how_to_bind():
    model, data, view = make_view("wxai")
    assert not view.is_bound
    with pytest.raises(UserError, match=r"not bound to an MjData.*RobotView\(data, groups\)"):
        view.get_qpos_dict()
    assert set(view.get_qpos_dict(data)) == {"arm", "gripper"}  # the earlier form works
    view.bind(data)
    assert view.get_move_group("arm").data is data


@pytest.mark.parametrize(("case", "frame"), FRAME_CASES)
def test_bound_jacobian_matches_the_earlier_form_and_finite_differences(case, frame):
    model, data, view = bound_view(case)
    set_test_pose(model, data, view)
    inputs = [frame]
    jac = view.get_jacobian(frame, inputs)
    group = view.get_move_group(frame)
    assert jac.shape == (6, group.vel_dim)
    np.testing.assert_array_equal(jac, view.get_jacobian(data, frame, inputs))
    q0 = group.joint_pos
    eps = 1e-6
    for col in range(group.vel_dim):
        plus, minus = q0.copy(), q0.copy()
        plus[col] += eps
        minus[col] -= eps
        group.joint_pos = plus
        mujoco.mj_kinematics(model, data)
        p_plus = group.leaf_frame_to_world
        group.joint_pos = minus
        mujoco.mj_kinematics(model, data)
        p_minus = group.leaf_frame_to_world
        lin = (p_plus[:3, 3] - p_minus[:3, 3]) / (2 * eps)
        rot = p_plus[:3, :3] @ p_minus[:3, :3].T
        ang = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
        np.testing.assert_allclose(jac[:3, col], lin, atol=1e-6)
        np.testing.assert_allclose(jac[3:, col], ang / (4 * eps), atol=1e-6)


def test_bound_jacobian_over_several_groups():
    model, data, view = bound_view("kit_joint")
    set_test_pose(model, data, view)
    jac = view.get_jacobian("right_arm", ["left_arm", "right_arm", "right_gripper"])
    assert jac.shape == (6, 6 + 6 + 2)
    np.testing.assert_array_equal(jac[:, :6], 0.0)  # the left arm does not move the right tool
    np.testing.assert_array_equal(jac[:, 12:], 0.0)
    np.testing.assert_array_equal(jac[:, 6:12], view.get_jacobian("right_arm", ["right_arm"]))
    full = view.get_jacobian("right_arm")  # default: every group's dofs
    assert full.shape == (6, model.nv - 6)  # all but the box's free joint
    grip = view.get_jacobian("right_gripper", ["right_gripper"])  # any group has a leaf frame
    assert grip.shape == (6, 2) and np.abs(grip).max() > 0.5
