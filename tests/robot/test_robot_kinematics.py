"""RobotKinematics: FK of every group against the reference poses, base placement, and the
damped-least-squares IK (targets reached, limits kept, options checked)."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot import Robot, RobotKinematics
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config, wxai_config
from trossen_arm_mujoco.robot.frames import pose7_to_transform, pose_error

FK = json.loads((Path(__file__).parents[1] / "fixtures" / "fk_reference.json").read_text())
WXAI = Path(ASSETS_DIR) / "wxai/wxai_follower.xml"
KIT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene_joint.xml"
PLACED = pose7_to_transform([0.4, -0.3, 0.1, np.cos(0.3), 0.0, 0.0, np.sin(0.3)])


def same_pose(tf, pos, quat, tol=1e-6) -> bool:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(tf[:3, :3]).reshape(9))
    quat = np.asarray(quat)
    return (
        np.abs(tf[:3, 3] - pos).max() < tol
        and min(np.abs(q - quat).max(), np.abs(q + quat).max()) < tol
    )


@pytest.fixture(scope="module")
def wxai_kin():
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    return RobotKinematics(model, wxai_config())


@pytest.mark.parametrize("k", range(10))
def test_fk_matches_the_reference(wxai_kin, k):
    config = np.asarray(FK["config"][k])
    fk = wxai_kin.fk({"arm": config[:6], "gripper": config[6:]})
    assert set(fk) == {"base", "arm", "gripper"}
    assert same_pose(fk["arm"], FK["ee_pos"][k], FK["ee_quat"][k])
    np.testing.assert_allclose(fk["base"], np.eye(4), atol=1e-12)
    rel = wxai_kin.fk({"arm": config[:6]}, rel_to_base=True)  # base at the origin
    np.testing.assert_allclose(rel["arm"], fk["arm"], atol=1e-12)


@pytest.mark.parametrize("case", sorted(FK["bimanual_world_frame"]["cases"]))
def test_fk_kit_world_and_base_frames(case):
    model = mujoco.MjModel.from_xml_path(str(KIT))
    kin = RobotKinematics(model, stationary_ai_joint_config())
    arms = FK["bimanual_world_frame"]["cases"][case]
    qpos = {f"{s}_arm": arms[s]["config"][:6] for s in ("left", "right")}
    fk = kin.fk(qpos)
    rel = kin.fk(qpos, rel_to_base=True)
    for side in ("left", "right"):
        ref = arms[side]
        assert same_pose(fk[f"{side}_arm"], ref["ee_site_pos"], ref["ee_site_quat"])
        base = fk[f"{side}_base"]
        np.testing.assert_allclose(
            rel[f"{side}_arm"], np.linalg.inv(base) @ fk[f"{side}_arm"], atol=1e-12
        )
    # placing the primary (left) base moves everything rigidly, the right base included
    placed = kin.fk(qpos, base_pose=PLACED)
    move = PLACED @ np.linalg.inv(fk["left_base"])
    for name in fk:
        np.testing.assert_allclose(placed[name], move @ fk[name], atol=1e-12)
    np.testing.assert_allclose(placed["left_base"], PLACED, atol=1e-12)


def test_fk_reads_the_reference_and_never_writes_it():
    model = mujoco.MjModel.from_xml_path(str(KIT))
    data = mujoco.MjData(model)
    robot = Robot(data, stationary_ai_joint_config())
    robot.reset()
    data.qpos[8:14] = [0.3, 0.9, 0.7, 0.2, -0.3, 0.5]  # the right arm, live
    mujoco.mj_kinematics(model, data)
    before = data.qpos.copy(), data.site_xpos.copy()
    fk = robot.kinematics.fk({"left_arm": np.zeros(6)})
    right = robot.robot_view.get_move_group("right_arm")
    np.testing.assert_allclose(fk["right_arm"], right.leaf_frame_to_world, atol=1e-12)  # live
    np.testing.assert_array_equal(data.qpos, before[0])
    np.testing.assert_array_equal(data.site_xpos, before[1])
    unbound = RobotKinematics(model, stationary_ai_joint_config())  # model defaults
    np.testing.assert_array_equal(unbound.reference_state()[0], model.qpos0)


def random_configs(group, rng, n):
    limits = group.joint_pos_limits
    return rng.uniform(limits[:, 0], limits[:, 1], size=(n, len(limits)))


def test_ik_reaches_fk_targets_within_limits(wxai_kin):
    rng = np.random.default_rng(7)
    arm = wxai_kin.robot_view.get_move_group("arm")
    limits = arm.joint_pos_limits
    for q_true in random_configs(arm, rng, 12):
        target = wxai_kin.fk({"arm": q_true})["arm"]
        start = np.clip(q_true + rng.uniform(-0.3, 0.3, 6), limits[:, 0], limits[:, 1])
        result = wxai_kin.solve_ik("arm", target, q0={"arm": start}, eps=1e-8)
        assert result.converged and result.residual < 1e-8, result
        q = result.qpos["arm"]
        assert np.all(q >= limits[:, 0]) and np.all(q <= limits[:, 1])
        reached = wxai_kin.fk({"arm": q})["arm"]
        assert np.linalg.norm(pose_error(target, reached)) < 1e-8
        assert set(result.qpos) == {"arm", "gripper"}


def test_ik_unreachable_returns_none_and_keeps_limits(wxai_kin):
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.2]
    assert wxai_kin.ik("arm", far, max_iter=30) is None
    result = wxai_kin.solve_ik("arm", far, max_iter=30)
    assert not result.converged and result.residual > 0.5 and result.iterations == 30
    limits = wxai_kin.robot_view.get_move_group("arm").joint_pos_limits
    q = result.qpos["arm"]
    assert np.all(q >= limits[:, 0]) and np.all(q <= limits[:, 1])


def test_ik_targets_in_the_base_frame_and_with_a_placed_base(toy):
    model = toy.model("fixed")  # base at (0.1, -0.2, 0.3), yawed 45 degrees
    kin = RobotKinematics(model, toy.config("fixed"))
    q_true = np.array([0.4, -0.6, 0.04])
    rel = kin.fk({"arm": q_true}, rel_to_base=True)["arm"]
    world = kin.fk({"arm": q_true})["arm"]
    assert np.abs(rel - world).max() > 0.1
    start = {"arm": [0.2, -0.3, 0.05]}
    for pose, kwargs in ((rel, {"rel_to_base": True}), (PLACED @ rel, {"base_pose": PLACED})):
        q = kin.ik("arm", pose, q0=start, eps=1e-9, **kwargs)
        assert q is not None
        np.testing.assert_allclose(kin.fk(q, rel_to_base=True)["arm"], rel, atol=1e-8)


def test_ik_over_several_groups_and_unlocked_errors(toy):
    model = toy.model("free")
    kin = RobotKinematics(model, toy.config("free"))
    target = kin.fk({"arm": [0.4, -0.6, 0.04]})["arm"]
    q = kin.ik("arm", target, ["arm", "gripper"], q0={"arm": [0.2, -0.3, 0.05]}, eps=1e-8)
    assert q is not None and set(q) == {"base", "arm", "gripper"}
    with pytest.raises(UserError, match="IK moves hinge and slide joints; move group 'base'"):
        kin.ik("arm", target, ["base", "arm"])
    with pytest.raises(UserError, match="unknown move group 'hand'"):
        kin.ik("hand", target)
    with pytest.raises(UserError, match="no joints to move"):
        RobotKinematics(toy.model("fixed"), toy.config("fixed")).ik("arm", target, [])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"eps": -1.0}, "eps must be"),
        ({"max_iter": 2.5}, "max_iter must be a whole number"),
        ({"damping": 0.0}, "damping must be a positive"),
        ({"max_step": 0.0}, "max_step must be a positive"),
        ({"pose": np.full((4, 4), np.nan)}, "IK target pose: contains NaN"),
        ({"q0": {"arm": [0.0] * 5}}, "expected 6 joint values"),
    ],
)
def test_bad_ik_input_fails_in_one_line(wxai_kin, kwargs, match):
    args = {"pose": np.eye(4), **kwargs}
    with pytest.raises(UserError, match=match) as err:
        wxai_kin.ik("arm", **args)
    assert "\n" not in str(err.value)
