"""FK of the Mobile AI's arms against the URDF chain: each arm's tool frame is the Mobile AI
URDF's mount of that arm on base_link composed with the WidowX AI chain (the reference poses
of ``fixtures/fk_reference.json``, arm base frame), wherever the base stands."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.robot import Robot, RobotKinematics
from trossen_arm_mujoco.robot.configs import mobile_ai_config
from trossen_arm_mujoco.robot.frames import pose7_to_transform

FK = json.loads((Path(__file__).parents[1] / "fixtures" / "fk_reference.json").read_text())
MOBILE = Path(ASSETS_DIR) / "mobile_ai" / "mobile_ai.xml"
#: Mobile AI URDF (trossen_arm_description urdf/generated/mobile_ai.urdf): base_link is
#: 0.211 m above base_footprint; follower_{left,right}/mount_joint at (0.331, +-0.3, 0.831)
#: in base_link, no rotation.
BASE_LINK_HEIGHT = 0.211
MOUNTS = {"left": (0.331, 0.3, 0.831), "right": (0.331, -0.3, 0.831)}
#: Where the base is put: at home, and turned and moved on the floor.
BASE_POSES = {
    "home": (0.0, 0.0, 0.0),
    "moved": (1.3, -0.7, 2.2),
}


def translation(xyz) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = xyz
    return t


def expected(side: str, k: int, base: np.ndarray) -> np.ndarray:
    """The URDF chain: base_link pose, the arm's mount, then the wxai reference pose."""
    ref = pose7_to_transform([*FK["ee_pos"][k], *FK["ee_quat"][k]])
    return base @ translation(MOUNTS[side]) @ ref


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(MOBILE))


@pytest.mark.parametrize("where", sorted(BASE_POSES))
@pytest.mark.parametrize("k", range(len(FK["config"])))
def test_arm_fk_matches_the_urdf_chain(model, k, where):
    x, y, yaw = BASE_POSES[where]
    base = pose7_to_transform([x, y, BASE_LINK_HEIGHT, np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
    kin = RobotKinematics(model, mobile_ai_config())
    q = np.asarray(FK["config"][k])
    fk = kin.fk(
        {"left_arm": q[:6], "left_gripper": q[6:], "right_arm": q[:6], "right_gripper": q[6:]},
        base_pose=base,
    )
    np.testing.assert_allclose(fk["base"], base, atol=1e-12)
    for side in ("left", "right"):
        want = expected(side, k, base)
        np.testing.assert_allclose(fk[f"{side}_arm"][:3, 3], want[:3, 3], atol=1e-6)
        np.testing.assert_allclose(fk[f"{side}_arm"][:3, :3], want[:3, :3], atol=1e-6)
        np.testing.assert_allclose(fk[f"{side}_base"], base @ translation(MOUNTS[side]), atol=1e-9)


def test_arm_fk_follows_the_simulated_base(model):
    """The live robot: after driving and turning, each tool frame (ee_site) is where the URDF
    chain puts it from the base's pose."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    robot = Robot(model, mobile_ai_config(), ctrl_dt=0.02, data=data)
    robot.reset()
    robot.update_control({"base": (0.4, 0.6)})
    for _ in range(50):
        robot.apply_control()
        mujoco.mj_step(model, data, nstep=10)
    mujoco.mj_forward(model, data)
    base = robot.get_world_pose()
    for side in ("left", "right"):
        arm = robot.view.get_move_group(f"{side}_arm")
        start = np.asarray(FK["config"][1])  # START_ARM_POSE, where reset put the arms
        np.testing.assert_allclose(arm.joint_pos, start[:6], atol=2e-3)
        ref = pose7_to_transform([*FK["ee_pos"][1], *FK["ee_quat"][1]])
        # the arm's joints as they are now (within 2 mrad of START): compare through FK
        kin_now = robot.kinematics.fk({f"{side}_arm": arm.joint_pos})[f"{side}_arm"]
        np.testing.assert_allclose(arm.leaf_frame_to_world, kin_now, atol=1e-9)
        np.testing.assert_allclose(
            arm.leaf_frame_to_world[:3, 3],
            (base @ translation(MOUNTS[side]) @ ref)[:3, 3],
            atol=2e-3,
        )
