"""MJCFFrameMixin: the leaf frame named in the MJCF (a site or a body): its pose, position and
Jacobian, checked against MuJoCo, finite differences and the vendor model's FK reference."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.arm_groups import ArmMoveGroup
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin

ASSETS = Path(ASSETS_DIR)
ARM_JOINTS = [f"joint_{i}" for i in range(6)]


def test_frame_pose_and_unknown_site(wxai):
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    mujoco.mj_kinematics(wxai, data)
    np.testing.assert_allclose(arm.get_frame_pose(data), [0.2537, 0, 0.1635, 1, 0, 0, 0], atol=1e-9)
    with pytest.raises(UserError, match="unknown site 'tool'.*ee_site"):
        ArmMoveGroup(wxai, "arm", ARM_JOINTS, ARM_JOINTS, "tool")


@pytest.mark.parametrize(("frame", "frame_type"), [("tool", "site"), ("link3", "body")])
def test_get_jacobian_matches_finite_differences(toy, toy_model, frame, frame_type):
    """Both the linear and the angular rows, for a site and a body leaf frame."""
    data = mujoco.MjData(toy_model)
    arm = toy.arm(data, frame, frame_type)
    assert arm.leaf_frame_type == frame_type
    q0 = np.array([0.4, -0.7, 0.03])
    arm.joint_pos = q0
    mujoco.mj_forward(toy_model, data)
    jac = arm.get_jacobian()
    assert jac.shape == (6, toy_model.nv)
    eps = 1e-6
    for j in range(3):
        poses = []
        for sign in (1, -1):
            q = q0.copy()
            q[j] += sign * eps
            arm.joint_pos = q
            mujoco.mj_kinematics(toy_model, data)
            poses.append(arm.leaf_frame_to_world)
        lin = (poses[0][:3, 3] - poses[1][:3, 3]) / (2 * eps)
        rot = poses[0][:3, :3] @ poses[1][:3, :3].T
        ang = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]]) / 2
        np.testing.assert_allclose(jac[:3, j], lin, atol=1e-7)
        np.testing.assert_allclose(jac[3:, j], ang / (2 * eps), atol=1e-7)
    np.testing.assert_array_equal(jac[:, 3:], 0.0)  # the fingers do not move the frame


def test_mjcf_frame_mixin_site_and_body(toy, toy_model):
    data = mujoco.MjData(toy_model)
    body_frame = toy.arm(data, "link3", "body")
    assert isinstance(body_frame, MJCFFrameMixin)
    assert body_frame.leaf_frame_id == toy_model.body("link3").id
    mujoco.mj_kinematics(toy_model, data)
    np.testing.assert_array_equal(
        body_frame.get_frame_position(data), data.xpos[body_frame.leaf_frame_id]
    )
    np.testing.assert_array_equal(
        body_frame.get_frame_pose(data)[3:], data.xquat[body_frame.leaf_frame_id]
    )
    assert body_frame.frame_site_id == -1 and body_frame.frame_site_name == ""
    from trossen_arm_mujoco.robot.controllers import EEDeltaController

    with pytest.raises(UserError, match="IK needs a site as the tool frame"):
        EEDeltaController(body_frame, toy_model)
    assert toy.arm(data).frame_site_id == toy_model.site("tool").id
    with pytest.raises(UserError, match="must be 'site' or 'body'"):
        toy.arm(data, "tool", "geom")
    with pytest.raises(UserError, match="unknown body 'tool'"):
        toy.arm(data, "tool", "body")


def test_wxai_tool_frame_agrees_with_the_fk_reference(wxai):
    import json

    fk = json.loads((Path(__file__).parents[1] / "fixtures" / "fk_reference.json").read_text())
    data = mujoco.MjData(wxai)
    arm = ArmMoveGroup(data, "arm", ARM_JOINTS, ARM_JOINTS, "ee_site")
    for k in range(len(fk["config"])):
        data.qpos[:] = fk["config"][k]
        mujoco.mj_kinematics(wxai, data)
        leaf = arm.leaf_frame_to_world
        np.testing.assert_allclose(leaf[:3, 3], fk["ee_pos"][k], atol=1e-6)
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, leaf[:3, :3].reshape(9))
        ref = np.asarray(fk["ee_quat"][k])
        assert min(np.abs(quat - ref).max(), np.abs(quat + ref).max()) < 1e-6
