"""Every shipped model compiles and is sane; every name the code looks up exists."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from dm_control import mujoco as dm_mujoco

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE, STATIONARY_CAMERAS
from trossen_arm_mujoco.names import names_of
from trossen_arm_mujoco.tasks.transfer_cube import TransferCubeReward

ASSETS = Path(ASSETS_DIR)
ALL_XML = sorted(ASSETS.rglob("*.xml"))
KIT_SCENES = ["stationary_ai/trossen_ai_scene.xml", "stationary_ai/trossen_ai_scene_joint.xml"]
GEOMS = ["red_box", "table", "left/gripper_follower_left", "right/gripper_follower_left"]


def rel(path: Path) -> str:
    return path.relative_to(ASSETS).as_posix()


def test_the_known_models_are_shipped():
    shipped = {rel(p) for p in ALL_XML}
    assert {"wxai/wxai_follower.xml", "stationary_ai/trossen_ai.xml", *KIT_SCENES} <= shipped


@pytest.mark.parametrize("xml", ALL_XML, ids=rel)
def test_model_compiles_and_steps_cleanly(xml):
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_step(model, data, int(0.5 / model.opt.timestep))
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    warnings = [
        mujoco.mjtWarning(i).name for i in range(len(data.warning)) if data.warning[i].number
    ]
    assert warnings == []


@pytest.mark.parametrize("xml", ALL_XML, ids=rel)
def test_model_loads_in_dm_control(xml):
    physics = dm_mujoco.Physics.from_xml_path(str(xml))
    assert physics.model.nq == physics.model.ptr.nq


@pytest.mark.parametrize("scene", KIT_SCENES)
def test_kit_scene_names(scene):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / scene))
    cameras = names_of(model, "camera")
    assert cameras == list(STATIONARY_CAMERAS)  # also the recording order
    geoms = names_of(model, "geom")
    for geom in GEOMS + ["left/gripper_follower_right", "right/gripper_follower_right"]:
        assert geom in geoms
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "red_box_joint")
    assert jid == 16
    assert model.jnt_qposadr[jid] == 16
    assert model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_FREE
    assert model.nq == 23 and model.nv == 22
    TransferCubeReward(model)  # looks up its geoms; raises if any is missing
    for side in ("left", "right"):
        assert f"{side}/ee_site" in names_of(model, "site")
        assert f"{side}/gripper" in names_of(model, "actuator")
    assert "home" in names_of(model, "key")


def test_dm_control_name_lookups_of_the_public_api():
    """The lookups users' task code makes through dm_control's Physics."""
    physics = dm_mujoco.Physics.from_xml_path(str(ASSETS / KIT_SCENES[1]))
    assert physics.model.name2id("red_box_joint", "joint") == 16
    for geom in GEOMS:
        gid = physics.model.name2id(geom, "geom")
        assert physics.model.id2name(gid, "geom") == geom
    physics.named.data.qpos[:16] = START_ARM_POSE
    np.testing.assert_allclose(physics.named.data.qpos["left/joint_1"], np.pi / 12)
    np.testing.assert_allclose(physics.named.data.qpos["red_box_joint"][:3], [0, 0, 0.0325])


def test_mocap_scene_bodies():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / KIT_SCENES[0]))
    assert model.nmocap == 2
    for mocap_id, side in enumerate(("left", "right")):
        body = model.body(f"mocap_{side}")
        assert body.mocapid[0] == mocap_id
    assert names_of(model, "equality")[-2:] == ["mocap_left_weld", "mocap_right_weld"]
    assert model.nu == 2  # only the grippers are actuated


def test_joint_scene_actuators():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / KIT_SCENES[1]))
    expected = [
        f"{s}/{j}"
        for s in ("left", "right")
        for j in [*(f"joint_{i}" for i in range(6)), "gripper"]
    ]
    assert names_of(model, "actuator") == expected
    # each arm actuator drives the joint of the same name; ranges are the joint ranges
    for i in range(model.nu):
        jid = model.actuator_trnid[i, 0]
        np.testing.assert_allclose(model.actuator_ctrlrange[i], model.jnt_range[jid])


def test_home_keyframes_match_start_pose():
    for scene in KIT_SCENES:
        model = mujoco.MjModel.from_xml_path(str(ASSETS / scene))
        key = model.key("home")
        np.testing.assert_allclose(key.qpos[:16], START_ARM_POSE)
        np.testing.assert_allclose(key.qpos[16:], [0, 0, 0.0325, 1, 0, 0, 0])
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    np.testing.assert_allclose(model.key("home").qpos, START_ARM_POSE[:8])


def test_mocap_home_matches_tool_frame_at_start_pose():
    """The mocap targets of the home keyframe are the ee_site poses at START_ARM_POSE."""
    model = mujoco.MjModel.from_xml_path(str(ASSETS / KIT_SCENES[0]))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    for mocap_id, side in enumerate(("left", "right")):
        sid = model.site(f"{side}/ee_site").id
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, data.site_xmat[sid])
        np.testing.assert_allclose(data.mocap_pos[mocap_id], data.site_xpos[sid], atol=1e-6)
        assert abs(abs(quat @ data.mocap_quat[mocap_id]) - 1) < 1e-9


def test_offscreen_buffer_fits_recording_size():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / KIT_SCENES[1]))
    assert model.vis.global_.offwidth >= 640 and model.vis.global_.offheight >= 480
