"""ParallelKinematics: batched FK equals the single FK; batched IK reaches FK targets within
limits and equals the single solver for the same targets and initial joints."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot import ParallelKinematics, Robot, RobotKinematics
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config, wxai_config
from trossen_arm_mujoco.robot.frames import pose7_to_transform

WXAI = Path(ASSETS_DIR) / "wxai/wxai_follower.xml"
KIT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene_joint.xml"
PLACED = pose7_to_transform([0.4, -0.3, 0.1, np.cos(0.3), 0.0, 0.0, np.sin(0.3)])


@pytest.fixture(scope="module")
def wxai():
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    kin = RobotKinematics(model, wxai_config())
    return kin, ParallelKinematics(kin, "arm")


def random_arm_configs(kin, name, rng, n):
    limits = kin.robot_view.get_move_group(name).joint_pos_limits
    return rng.uniform(limits[:, 0], limits[:, 1], size=(n, len(limits)))


def test_batched_fk_equals_single_fk(wxai):
    kin, par = wxai
    rng = np.random.default_rng(0)
    qs = random_arm_configs(kin, "arm", rng, 16)
    fingers = rng.uniform(0, 0.044, size=(16, 1)).repeat(2, axis=1)
    dicts = [{"arm": q, "gripper": f} for q, f in zip(qs, fingers)]
    for kwargs in ({}, {"rel_to_base": True}, {"base_poses": PLACED}):
        batched = par.fk(dicts, **kwargs)
        assert len(batched) == 16
        for qd, got in zip(dicts, batched):
            single = kin.fk(
                qd, base_pose=kwargs.get("base_poses"), rel_to_base=kwargs.get("rel_to_base", False)
            )
            assert set(got) == set(single) == {"base", "arm", "gripper"}
            for name in single:
                np.testing.assert_allclose(got[name], single[name], atol=1e-12, err_msg=name)
    one = par.fk(dicts[3])  # a single dict gives a single dict
    np.testing.assert_allclose(one["arm"], kin.fk(dicts[3])["arm"], atol=1e-12)
    poses = par.leaf_poses(qs)
    assert poses.shape == (16, 4, 4)
    np.testing.assert_allclose(poses[5], kin.fk({"arm": qs[5]})["arm"], atol=1e-12)


def test_batched_fk_per_configuration_base_poses(wxai):
    kin, par = wxai
    rng = np.random.default_rng(1)
    qs = random_arm_configs(kin, "arm", rng, 3)
    bases = np.stack(
        [
            pose7_to_transform(np.r_[rng.normal(size=3), q / np.linalg.norm(q)])
            for q in rng.normal(size=(3, 4))
        ]
    )
    poses = par.leaf_poses(qs, base_poses=bases)
    for i in range(3):
        np.testing.assert_allclose(
            poses[i], kin.fk({"arm": qs[i]}, base_pose=bases[i])["arm"], atol=1e-12
        )


def test_batched_fk_on_the_kit_every_group():
    model = mujoco.MjModel.from_xml_path(str(KIT))
    data = mujoco.MjData(model)
    robot = Robot(data, stationary_ai_joint_config())
    robot.reset()
    par = robot.get_parallel_kinematics("right_arm")
    rng = np.random.default_rng(2)
    dicts = [
        {
            "left_arm": rng.uniform(-0.5, 0.5, 6) + [0, 1, 1, 0, 0, 0],
            "right_arm": rng.uniform(-0.5, 0.5, 6) + [0, 1, 1, 0, 0, 0],
        }
        for _ in range(4)
    ]
    for qd, got in zip(dicts, par.fk(dicts)):
        single = robot.kinematics.fk(qd)
        for name in single:
            np.testing.assert_allclose(got[name], single[name], atol=1e-12, err_msg=name)


@pytest.fixture(scope="module")
def targets(wxai):
    """FK targets of random valid configurations, and starts 0.4 rad off them."""
    kin, par = wxai
    rng = np.random.default_rng(3)
    q_true = random_arm_configs(kin, "arm", rng, 24)
    limits = kin.robot_view.get_move_group("arm").joint_pos_limits
    start = np.clip(q_true + rng.uniform(-0.4, 0.4, q_true.shape), limits[:, 0], limits[:, 1])
    return par.leaf_poses(q_true), start


def test_batched_ik_reaches_targets_within_limits(wxai, targets):
    kin, par = wxai
    poses, start = targets
    result = par.solve(poses, start, eps=1e-8)
    assert result.q.shape == (24, 6)
    assert result.converged.all(), result.residual
    assert np.all(result.residual < 1e-8)
    limits = kin.robot_view.get_move_group("arm").joint_pos_limits
    assert np.all(result.q >= limits[:, 0]) and np.all(result.q <= limits[:, 1])
    reached = par.leaf_poses(result.q)
    np.testing.assert_allclose(reached, poses, atol=1e-7)


def test_batched_ik_equals_the_single_solver(wxai, targets):
    kin, par = wxai
    poses, start = targets
    # from the home pose some targets are not reached in 40 steps: both must agree on that too
    home = np.tile(kin.robot_view.get_move_group("arm").joint_pos, (len(poses), 1))
    for q0, kwargs in ((start, {"eps": 1e-8}), (home, {"eps": 1e-6, "max_iter": 40})):
        batched = par.solve(poses, q0, **kwargs)
        for i in range(len(poses)):
            single = kin.solve_ik("arm", poses[i], q0={"arm": q0[i]}, **kwargs)
            assert single.iterations == batched.iterations[i]
            assert single.converged == batched.converged[i]
            np.testing.assert_allclose(batched.q[i], single.qpos["arm"], atol=1e-7)
            assert batched.residual[i] == pytest.approx(single.residual, abs=1e-7)
    assert not par.solve(poses, home, eps=1e-6, max_iter=40).converged.all()


def test_batched_ik_is_deterministic_and_the_dict_form(wxai, targets):
    kin, par = wxai
    poses, start = targets
    a = par.solve(poses, start, eps=1e-8)
    b = par.solve(poses, start, eps=1e-8)
    np.testing.assert_array_equal(a.q, b.q)
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.2]
    dicts = [{"arm": start[0]}, {"arm": start[1]}]
    out = par.ik(np.stack([poses[0], far]), dicts, eps=1e-8, max_iter=50)
    assert out[1] is None  # 2 m away: out of reach
    assert set(out[0]) == {"arm", "gripper"}
    np.testing.assert_allclose(out[0]["arm"], a.q[0], atol=1e-12)
    single = par.ik(poses[0], {"arm": start[0]}, eps=1e-8)  # one pose, one dict
    np.testing.assert_allclose(single["arm"], a.q[0], atol=1e-12)
    par.warmup_ik(8)


def test_batched_ik_with_placed_bases_and_in_the_base_frame(toy):
    model = toy.model("fixed")
    kin = RobotKinematics(model, toy.config("fixed"))
    par = ParallelKinematics(kin, "arm", ["arm", "gripper"])
    assert par.n_unlocked == 5
    rng = np.random.default_rng(4)
    q_true = np.c_[rng.uniform(-1, 1, (6, 2)), rng.uniform(0.02, 0.08, 6), np.zeros((6, 2))]
    rel = par.leaf_poses(q_true, rel_to_base=True)
    start = np.clip(
        q_true + rng.uniform(-0.2, 0.2, q_true.shape), [-2, -9, 0, 0, 0], [2, 9, 0.1, 0.03, 0.03]
    )
    by_rel = par.solve(rel, start, rel_to_base=True, eps=1e-9)
    by_world = par.solve(PLACED @ rel, start, base_poses=PLACED, eps=1e-9)
    assert by_rel.converged.all() and by_world.converged.all()
    np.testing.assert_allclose(by_world.q, by_rel.q, atol=1e-7)
    np.testing.assert_allclose(par.leaf_poses(by_rel.q, rel_to_base=True), rel, atol=1e-8)
    for i in range(len(rel)):  # equal to the single solver over the same unlocked groups
        single = kin.solve_ik(
            "arm",
            rel[i],
            ["arm", "gripper"],
            {"arm": start[i, :3], "gripper": start[i, 3:]},
            rel_to_base=True,
            eps=1e-9,
        )
        np.testing.assert_allclose(by_rel.q[i, :3], single.qpos["arm"], atol=1e-7)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda p: p.solve(np.eye(4), np.zeros((2, 5))), r"q0: expected shape \(2, 6\)"),
        (lambda p: p.solve(np.zeros((3, 4, 4)), None), "poses: the 3x3 rotation block"),
        (lambda p: p.solve(np.eye(4), np.full((1, 6), np.nan)), "q0: contains NaN"),
        (
            lambda p: p.leaf_poses(np.zeros((2, 6)), base_poses=np.zeros((3, 4, 4))),
            r"expected \(2, 4, 4\)",
        ),
        (lambda p: p.fk([{"arm": [0.0] * 3}]), "configuration 0, arm: expected 6 finite"),
        (lambda p: p.ik(np.stack([np.eye(4)] * 2), [{}]), "1 initial configurations for 2 poses"),
        (lambda p: p.solve(np.eye(4), None, max_iter=-1), "max_iter must be"),
    ],
)
def test_bad_batches_fail_in_one_line(wxai, call, match):
    _, par = wxai
    with pytest.raises(UserError, match=match) as err:
        call(par)
    assert "\n" not in str(err.value)


def test_groups_the_chain_cannot_follow(toy):
    model = toy.model("free")
    kin = RobotKinematics(model, toy.config("free"))
    with pytest.raises(UserError, match="IK moves hinge and slide joints; move group 'base'"):
        ParallelKinematics(kin, "arm", ["base", "arm"])
    par = ParallelKinematics(kin, "arm")  # the chain hangs from the base: fine
    np.testing.assert_allclose(par.fk({})["arm"], kin.fk()["arm"], atol=1e-12)
