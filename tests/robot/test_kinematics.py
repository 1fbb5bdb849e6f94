"""Forward kinematics against the reference poses, and the differential IK of ``Kinematics``."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.robot.configs import wxai_config
from trossen_arm_mujoco.robot.kinematics import (
    Kinematics,
    damped_least_squares,
    orientation_error,
)

FK = json.loads((Path(__file__).parents[1] / "fixtures" / "fk_reference.json").read_text())
WXAI_XML = Path(ASSETS_DIR) / "wxai" / "wxai_follower.xml"
JOINT_SCENE = Path(ASSETS_DIR) / "stationary_ai" / "trossen_ai_scene_joint.xml"
TOL = 1e-6  # m, and per quaternion component


def quat_close(a, b, tol=TOL) -> bool:
    """Same rotation: q and -q are equal."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return min(np.abs(a - b).max(), np.abs(a + b).max()) < tol


def site_quat(data: mujoco.MjData, site_id: int) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[site_id])
    return quat


@pytest.fixture(scope="module")
def wxai():
    model = mujoco.MjModel.from_xml_path(str(WXAI_XML))
    return model, mujoco.MjData(model)


def test_reference_layout_matches_model(wxai):
    model, _ = wxai
    names = [model.joint(i).name for i in range(model.njnt)]
    assert names == FK["qpos_order"]
    assert len(FK["config"]) == 10


@pytest.mark.parametrize("k", range(10))
def test_fk_ee_site_and_link6_match_reference(wxai, k):
    model, data = wxai
    data.qpos[:] = FK["config"][k]
    mujoco.mj_kinematics(model, data)
    ee = model.site("ee_site").id
    link6 = model.body("link_6").id
    np.testing.assert_allclose(data.site_xpos[ee], FK["ee_pos"][k], atol=TOL)
    assert quat_close(site_quat(data, ee), FK["ee_quat"][k])
    np.testing.assert_allclose(data.xpos[link6], FK["link6_pos"][k], atol=TOL)
    assert quat_close(data.xquat[link6], FK["link6_quat"][k])


@pytest.mark.parametrize("case", sorted(FK["bimanual_world_frame"]["cases"]))
def test_fk_bimanual_world_frame(case):
    model = mujoco.MjModel.from_xml_path(str(JOINT_SCENE))
    data = mujoco.MjData(model)
    arms = FK["bimanual_world_frame"]["cases"][case]
    data.qpos[0:8] = arms["left"]["config"]
    data.qpos[8:16] = arms["right"]["config"]
    mujoco.mj_kinematics(model, data)
    for side in ("left", "right"):
        sid = model.site(f"{side}/ee_site").id
        np.testing.assert_allclose(data.site_xpos[sid], arms[side]["ee_site_pos"], atol=TOL)
        assert quat_close(site_quat(data, sid), arms[side]["ee_site_quat"])


@pytest.fixture(scope="module")
def arm_kinematics(wxai):
    model, _ = wxai
    group = wxai_config().build_view(model).get_move_group("arm")
    kin = Kinematics(model, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range)
    return model, kin


@pytest.mark.parametrize("k", [0, 2, 5, 8])
def test_kinematics_site_pose_matches_reference(arm_kinematics, k):
    _, kin = arm_kinematics
    qpos = np.asarray(FK["config"][k])
    pose = kin.site_pose(qpos)
    np.testing.assert_allclose(pose[:3], FK["ee_pos"][k], atol=TOL)
    assert quat_close(pose[3:], FK["ee_quat"][k])
    # q replaces the group joints of the full qpos
    pose2 = kin.site_pose(np.zeros(8), qpos[:6])
    np.testing.assert_allclose(pose2, pose, atol=1e-12)


def test_kinematics_never_touches_the_callers_data(wxai, arm_kinematics):
    model, data = wxai
    _, kin = arm_kinematics
    data.qpos[:] = FK["config"][3]
    mujoco.mj_kinematics(model, data)
    before_qpos, before_xpos = data.qpos.copy(), data.site_xpos.copy()
    kin.site_pose(np.asarray(FK["config"][4]))
    kin.jacobian(np.asarray(FK["config"][4]))
    kin.solve(data.qpos.copy(), np.array([0.3, 0.05, 0.25]), iterations=5)
    np.testing.assert_array_equal(data.qpos, before_qpos)
    np.testing.assert_array_equal(data.site_xpos, before_xpos)


def test_kinematics_jacobian_matches_finite_differences(arm_kinematics):
    _, kin = arm_kinematics
    qpos = np.asarray(FK["config"][2], dtype=float)
    jac = kin.jacobian(qpos)
    assert jac.shape == (6, 6)
    eps = 1e-6
    for j in range(6):
        qp, qm = qpos.copy(), qpos.copy()
        qp[j] += eps
        qm[j] -= eps
        pp, pm = kin.site_pose(qp), kin.site_pose(qm)
        np.testing.assert_allclose(jac[:3, j], (pp[:3] - pm[:3]) / (2 * eps), atol=1e-6)
        np.testing.assert_allclose(
            jac[3:, j], orientation_error(pp[3:], pm[3:]) / (2 * eps), atol=1e-6
        )


@pytest.mark.parametrize("k", [2, 3, 7])
def test_ik_solve_reaches_reference_poses(arm_kinematics, k):
    """From the start pose, IK finds joints whose FK is the reference pose of config k."""
    _, kin = arm_kinematics
    start = np.asarray(FK["config"][1], dtype=float)
    q, residual = kin.solve(start, np.asarray(FK["ee_pos"][k]), np.asarray(FK["ee_quat"][k]))
    assert residual < 1e-5
    pose = kin.site_pose(start, q)
    np.testing.assert_allclose(pose[:3], FK["ee_pos"][k], atol=1e-5)
    assert quat_close(pose[3:], FK["ee_quat"][k], tol=1e-5)
    assert np.all(q >= kin.joint_range[:, 0]) and np.all(q <= kin.joint_range[:, 1])


def test_ik_position_only(arm_kinematics):
    _, kin = arm_kinematics
    start = np.asarray(FK["config"][1], dtype=float)
    target = np.array([0.30, 0.05, 0.20])
    q, residual = kin.solve(start, target)
    assert residual < 1e-5
    np.testing.assert_allclose(kin.site_pose(start, q)[:3], target, atol=1e-5)


def test_ik_unreachable_target_stays_within_limits(arm_kinematics):
    _, kin = arm_kinematics
    start = np.asarray(FK["config"][1], dtype=float)
    q, residual = kin.solve(start, np.array([2.0, 0.0, 0.2]), iterations=50)
    assert residual > 0.5  # 2 m is out of reach; the error is reported, not hidden
    assert np.all(q >= kin.joint_range[:, 0] - 1e-12)
    assert np.all(q <= kin.joint_range[:, 1] + 1e-12)


def test_delta_step_moves_in_the_commanded_direction(arm_kinematics):
    _, kin = arm_kinematics
    qpos = np.asarray(FK["config"][1], dtype=float)
    p0 = kin.site_pose(qpos)[:3]
    for delta in ([0.01, 0, 0], [0, 0.01, 0], [0, 0, -0.01]):
        q = kin.delta_step(qpos, np.asarray(delta, float))
        moved = kin.site_pose(qpos, q)[:3] - p0
        np.testing.assert_allclose(moved, delta, atol=1e-3)


def test_delta_step_with_rotation(arm_kinematics):
    _, kin = arm_kinematics
    qpos = np.asarray(FK["config"][2], dtype=float)
    pose0 = kin.site_pose(qpos)
    twist = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.05])  # 0.05 rad about world z
    q = kin.delta_step(qpos, twist)
    pose1 = kin.site_pose(qpos, q)
    np.testing.assert_allclose(pose1[:3], pose0[:3], atol=1e-3)
    # one linearised step: first-order accurate
    np.testing.assert_allclose(orientation_error(pose1[3:], pose0[3:]), twist[3:], atol=5e-3)


def test_orientation_error_is_world_rotation_vector():
    identity = np.array([1.0, 0, 0, 0])
    half = np.sqrt(0.5)
    about_z = np.array([half, 0, 0, half])  # +90 deg about z
    np.testing.assert_allclose(orientation_error(about_z, identity), [0, 0, np.pi / 2], atol=1e-12)
    np.testing.assert_allclose(orientation_error(identity, about_z), [0, 0, -np.pi / 2], atol=1e-12)
    # q and -q are the same rotation: no 2*pi detour
    np.testing.assert_allclose(orientation_error(-about_z, about_z), 0.0, atol=1e-12)


def test_damped_least_squares_solves_well_posed_systems():
    rng = np.random.default_rng(0)
    jac = rng.normal(size=(3, 6))
    err = rng.normal(size=3)
    dq = damped_least_squares(jac, err, damping=1e-6)
    np.testing.assert_allclose(jac @ dq, err, atol=1e-8)
    # a singular Jacobian still gives a finite, bounded step
    singular = np.zeros((3, 6))
    singular[0, 0] = 1.0
    dq = damped_least_squares(singular, np.array([0.1, 1.0, 1.0]))
    assert np.all(np.isfinite(dq))
    np.testing.assert_allclose(dq[0], 0.1, atol=1e-6)


def test_delta_step_reuses_its_last_result_only_for_the_same_inputs(arm_kinematics, monkeypatch):
    model, kin = arm_kinematics
    qpos = np.zeros(model.nq)
    qpos[kin.qpos_idx] = [0.1, 0.8, 0.6, 0.0, 0.2, 0.0]
    twist = np.array([0.01, -0.02, 0.005])
    first = kin.delta_step(qpos, twist)
    solves = []
    monkeypatch.setattr(
        kin, "_load", lambda *a, **k: solves.append(1) or type(kin)._load(kin, *a, **k)
    )
    again = kin.delta_step(qpos, twist)
    assert not solves and np.array_equal(again, first)
    again[:] = 0.0  # a copy: the kept result is not the caller's array
    assert np.array_equal(kin.delta_step(qpos, twist), first)
    moved = qpos.copy()
    moved[kin.qpos_idx[0]] += 0.1
    assert not np.array_equal(kin.delta_step(moved, twist), first) and len(solves) == 1
    kin.delta_step(moved, twist * 2)
    kin.delta_step(moved, twist * 2, damping=0.01)
    assert len(solves) == 3
