"""KinematicChain: batched numpy FK and Jacobian equal MuJoCo's (hinge anchors, qpos0 from
``ref``, slides, rotated sites), and chains it cannot follow fail clearly."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.chain import KinematicChain


def mujoco_frame(model, data, kind, idx):
    if kind == "site":
        return data.site_xmat[idx].reshape(3, 3), data.site_xpos[idx]
    return data.xmat[idx].reshape(3, 3), data.xpos[idx]


@pytest.mark.parametrize("base", ["fixed", "mocap", "free"])
@pytest.mark.parametrize(("kind", "name"), [("site", "tool"), ("body", "finger_b")])
def test_chain_equals_mujoco(toy, base, kind, name):
    model = toy.model(base)
    data = mujoco.MjData(model)
    assert model.qpos0[model.jnt_qposadr[model.joint("j2").id]] == pytest.approx(0.3)  # ref
    frame = model.site(name).id if kind == "site" else model.body(name).id
    joints = ["j1", "j2", "j3", "fb"]
    adr = [int(model.jnt_qposadr[model.joint(j).id]) for j in joints]
    ref = model.body("base").id
    chain = KinematicChain(model, kind, frame, ref, {a: i for i, a in enumerate(adr)}, 4)
    rng = np.random.default_rng(0)
    qpos = np.tile(model.qpos0, (8, 1))
    qpos[:, adr] = rng.uniform([-2, -3, 0, 0], [2, 3, 0.1, 0.03], size=(8, 4))
    rot, pos, jac = chain.forward(qpos, jacobian=True)
    for i in range(8):
        data.qpos[:] = qpos[i]
        mujoco.mj_forward(model, data)
        base_rot = data.xmat[ref].reshape(3, 3)
        f_rot, f_pos = mujoco_frame(model, data, kind, frame)
        np.testing.assert_allclose(rot[i], base_rot.T @ f_rot, atol=1e-12)
        np.testing.assert_allclose(pos[i], base_rot.T @ (f_pos - data.xpos[ref]), atol=1e-12)
        full = np.zeros((6, model.nv))
        jac_fn = mujoco.mj_jacSite if kind == "site" else mujoco.mj_jacBody
        jac_fn(model, data, full[:3], full[3:], frame)
        dofs = [int(model.jnt_dofadr[model.joint(j).id]) for j in joints]
        expected = np.vstack([base_rot.T @ full[:3, dofs], base_rot.T @ full[3:, dofs]])
        np.testing.assert_allclose(jac[i], expected, atol=1e-12)
    rot2, pos2, none = chain.forward(qpos)
    assert none is None
    np.testing.assert_array_equal(rot2, rot)


def test_chain_from_the_world(toy):
    model = toy.model("fixed")
    data = mujoco.MjData(model)
    site = model.site("tool").id
    chain = KinematicChain(model, "site", site, 0)
    qpos = np.tile(model.qpos0, (2, 1))
    qpos[1, :3] = [0.5, -1.0, 0.05]
    rot, pos, _ = chain.forward(qpos)
    data.qpos[:] = qpos[1]
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(pos[1], data.site_xpos[site], atol=1e-12)
    np.testing.assert_allclose(rot[1], data.site_xmat[site].reshape(3, 3), atol=1e-12)


def test_chains_it_cannot_follow(toy):
    model = toy.model("mocap")
    with pytest.raises(UserError, match="'base' is a mocap body inside a kinematic chain"):
        KinematicChain(model, "site", model.site("tool").id, 0)
    model = toy.model("free")
    with pytest.raises(UserError, match="joint 'base_free' is not a hinge or slide"):
        KinematicChain(model, "site", model.site("tool").id, 0)
    with pytest.raises(UserError, match="frame site 'tool' is not below body 'finger_a'"):
        KinematicChain(model, "site", model.site("tool").id, model.body("finger_a").id)
