"""Joint and actuator indices of a move group, looked up once by name."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.joint_indices import (
    FREE,
    HINGE,
    SLIDE,
    actuator_ids,
    joint_indices,
    root_body_id,
)


def test_hinge_and_slide_joints(kit_joint):
    names = [f"right/joint_{i}" for i in range(6)] + ["right/left_carriage_joint"]
    idx = joint_indices(kit_joint, "right", names, (HINGE, SLIDE))
    np.testing.assert_array_equal(idx.joint_ids, [kit_joint.joint(n).id for n in names])
    np.testing.assert_array_equal(idx.qpos_idx, [kit_joint.joint(n).qposadr[0] for n in names])
    np.testing.assert_array_equal(idx.dof_idx, [kit_joint.joint(n).dofadr[0] for n in names])
    np.testing.assert_array_equal(idx.joint_range, [kit_joint.joint(n).range for n in names])
    assert idx.joint_range.shape == (7, 2)


def test_a_free_joint_takes_seven_positions_and_six_dofs(toy):
    model = toy.model("free")
    idx = joint_indices(model, "base", ["base_free"], (FREE,))
    np.testing.assert_array_equal(idx.qpos_idx, np.arange(7))
    np.testing.assert_array_equal(idx.dof_idx, np.arange(6))
    assert idx.joint_range.shape == (7, 2) and np.isinf(idx.joint_range).all()


def test_unlimited_joints_get_infinite_limits(toy_model):
    idx = joint_indices(toy_model, "arm", ["j1", "j2"], (HINGE, SLIDE))
    np.testing.assert_array_equal(idx.joint_range, [[-2, 2], [-np.inf, np.inf]])


def test_unknown_names_and_wrong_types_say_what_is_valid(kit_joint):
    with pytest.raises(UserError, match="unknown joint 'left/joint_9'.*left/joint_0"):
        joint_indices(kit_joint, "arm", ["left/joint_9"], (HINGE,))
    with pytest.raises(UserError, match="'red_box_joint' of move group 'box' is not a hinge"):
        joint_indices(kit_joint, "box", ["red_box_joint"], (HINGE,))
    with pytest.raises(UserError, match="unknown actuator 'motor'.*valid actuators"):
        actuator_ids(kit_joint, ["motor"])


def test_actuator_ids_in_the_given_order(kit_joint):
    names = ["right/joint_1", "left/joint_0"]
    np.testing.assert_array_equal(
        actuator_ids(kit_joint, names), [kit_joint.actuator(n).id for n in names]
    )


def test_root_body(toy_model):
    j1 = toy_model.joint("j1").id
    ids = np.array([j1])
    assert root_body_id(toy_model, None, ids) == toy_model.body("base").id  # j1's parent
    assert root_body_id(toy_model, "link1", ids) == toy_model.body("link1").id
    assert root_body_id(toy_model, np.int64(2), ids) == 2
    assert root_body_id(toy_model, None, np.zeros(0, dtype=int)) == 0  # the world
    with pytest.raises(UserError, match="unknown body 'nope'"):
        root_body_id(toy_model, "nope", ids)
