"""The Mobile AI model: names other code and helpers rely on, its facts (wheels, casters, arm
mounts, home keyframe), standing on its six wheels, and its three cameras rendering."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.assets import MOBILE_AI_CAMERAS, MOBILE_AI_TABLE_TOP
from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.names import names_of
from trossen_arm_mujoco.robot.configs import MOBILE_AI_BASE_HOME, MOBILE_AI_WHEEL_RADIUS

ASSETS = Path(ASSETS_DIR) / "mobile_ai"
MODELS = ["mobile_ai.xml", "mobile_ai_scene.xml"]
CAMERAS = ["cam_high", "cam_left_wrist", "cam_right_wrist"]
assert list(MOBILE_AI_CAMERAS) == CAMERAS
CASTERS = ["front_left", "front_right", "rear_left", "rear_right"]


def load(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(ASSETS / name))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


@pytest.mark.parametrize("name", MODELS)
def test_names_follow_the_stationary_kit(name):
    model, _ = load(name)
    assert names_of(model, "camera") == CAMERAS
    actuators = names_of(model, "actuator")
    arm = [f"joint_{i}" for i in range(6)] + ["gripper"]
    assert actuators == [f"left/{a}" for a in arm] + [f"right/{a}" for a in arm] + [
        "left_wheel",
        "right_wheel",
    ]
    joints = names_of(model, "joint")
    assert joints[0] == "base_joint" and {"left_wheel", "right_wheel"} <= set(joints)
    for side in ("left", "right"):
        assert model.site(f"{side}/ee_site").id >= 0
        assert model.body(f"{side}/base_link").parentid == model.body("base_link").id
    assert {"base_link", *(f"caster_wheel_{c}" for c in CASTERS)} <= set(names_of(model, "body"))
    assert model.actuator("left_wheel").trntype == mujoco.mjtTrn.mjTRN_JOINT
    assert model.actuator("left_wheel").gainprm[0] > 0  # a velocity servo


@pytest.mark.parametrize("name", MODELS)
def test_home_keyframe_and_layout(name):
    model, data = load(name)
    arm = list(START_ARM_POSE[:8])
    # qpos: base (7), left arm (8), right arm (8) as the kit's 16 values, wheels, casters
    np.testing.assert_allclose(data.qpos[:7], MOBILE_AI_BASE_HOME[:7])
    np.testing.assert_allclose(data.qpos[7:23], arm + arm)
    np.testing.assert_allclose(data.ctrl[:14], arm[:7] + arm[:7])
    np.testing.assert_array_equal(data.ctrl[14:], [0.0, 0.0])
    assert model.jnt_qposadr[model.joint("left_wheel").id] == 23


def test_wheels_facts_and_six_floor_contacts():
    model, data = load("mobile_ai.xml")
    wheel = model.geom("left_wheel")
    assert wheel.size[0] == pytest.approx(MOBILE_AI_WHEEL_RADIUS)
    # the axle's height (URDF: base_link 0.211 above the floor, wheel joint 0.1259 below it)
    assert data.xpos[model.body("left_wheel_link").id][2] == pytest.approx(0.0851)
    assert model.actuator("left_wheel").forcerange[1] == 4.0  # URDF wheel effort
    assert model.actuator("left_wheel").ctrlrange[1] == pytest.approx(4 * np.pi)  # URDF velocity
    assert sum(model.body_mass) == pytest.approx(80 + 2 * 3 + 4 * 0.635 + 2 * 4.11148, abs=0.01)
    mujoco.mj_step(model, data, 250)  # settle 0.5 s
    floor = model.geom("floor").id
    touching = sorted(
        model.geom(int(c.geom2 if c.geom1 == floor else c.geom1)).name
        for c in data.contact[: data.ncon]
        if floor in (c.geom1, c.geom2)
    )
    assert touching == sorted(["left_wheel", "right_wheel", *(f"caster_{c}" for c in CASTERS)])
    assert abs(data.qpos[2] - 0.211) < 1e-3  # resting, not sinking
    assert np.abs(data.qvel[:6]).max() < 1e-2


def test_scene_table_and_cube():
    model, data = load("mobile_ai_scene.xml")
    top = data.geom_xpos[model.geom("table").id][2] + model.geom("table").size[2]
    assert top == pytest.approx(MOBILE_AI_TABLE_TOP)
    cube = model.body("cube").id
    assert data.xpos[cube][2] - model.geom("cube").size[2] == pytest.approx(top)
    assert model.jnt_qposadr[model.joint("cube_joint").id] == 33
    assert model.site("target_site").id >= 0


def test_three_cameras_render():
    model, data = load("mobile_ai_scene.xml")
    assert (model.vis.global_.offheight, model.vis.global_.offwidth) == (480, 640)
    renderer = mujoco.Renderer(model, 24, 32)
    try:
        images = []
        for camera in CAMERAS:
            renderer.update_scene(data, camera)
            images.append(renderer.render().copy())
    finally:
        renderer.close()
    for camera, image in zip(CAMERAS, images):
        assert image.shape == (24, 32, 3) and image.std() > 5, camera
    assert not np.array_equal(images[1], images[2])  # two different wrists
