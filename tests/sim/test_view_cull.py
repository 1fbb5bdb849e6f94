"""View culling leaves out only what a frame cannot show: the same pixels, fewer geoms."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.sim.camera_crop import apply_crops, parse_crops
from trossen_arm_mujoco.sim.view_cull import ViewCull

KIT = f"{ASSETS_DIR}/stationary_ai/trossen_ai_scene_joint.xml"

#: A camera looking straight down at the floor around the origin; a box in view, a box out of
#: view whose shadow (the light shines along +x and down) falls into the view, and a box far
#: out of view whose shadow does not.
SHADOWS = """
<mujoco>
  <visual><quality shadowsize="512"/></visual>
  <worldbody>
    <light directional="true" castshadow="true" pos="0 0 3" dir="1 0 -1"/>
    <geom name="floor" type="plane" size="5 5 0.1" rgba="0.8 0.8 0.8 1"/>
    <camera name="down" pos="0 0 1" xyaxes="1 0 0 0 1 0" fovy="40"/>
    <geom name="seen" type="box" pos="0.1 0 0.05" size="0.05 0.05 0.05" rgba="1 0 0 1"/>
    <geom name="shadow_only" type="box" pos="-0.9 0 0.9" size="0.1 0.1 0.1" rgba="0 1 0 1"/>
    <geom name="gone" type="box" pos="2 2 0.1" size="0.1 0.1 0.1" rgba="0 0 1 1"/>
  </worldbody>
</mujoco>
"""


def frames(model, data, camera, size, cull: bool) -> tuple[np.ndarray, int, int]:
    renderer = mujoco.Renderer(model, *size)
    try:
        if cull:
            hidden = ViewCull(model).update_scene(renderer, data, camera)
        else:
            renderer.update_scene(data, camera=camera)
            hidden = 0
        ngeom = renderer.scene.ngeom
        return renderer.render().copy(), hidden, ngeom
    finally:
        renderer.close()


def test_a_shadow_from_outside_the_view_is_kept_and_the_rest_left_out():
    model = mujoco.MjModel.from_xml_string(SHADOWS)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = model.camera("down").id
    plain, _, ngeom = frames(model, data, cam, (48, 64), cull=False)
    culled, hidden, ngeom_culled = frames(model, data, cam, (48, 64), cull=True)
    assert hidden == 1 and ngeom_culled == ngeom - 1  # only "gone"
    np.testing.assert_array_equal(plain, culled)
    groups = model.geom_group.copy()
    model.geom_group[model.geom("shadow_only").id] = 5  # its shadow is in the frame
    assert not np.array_equal(frames(model, data, cam, (48, 64), cull=False)[0], plain)
    model.geom_group[:] = groups
    # without the light's shadows the shadow-only box is left out too, the frame the same
    model.light_castshadow[:] = 0
    plain, _, _ = frames(model, data, cam, (48, 64), cull=False)
    culled, hidden, _ = frames(model, data, cam, (48, 64), cull=True)
    assert hidden == 2
    np.testing.assert_array_equal(plain, culled)
    np.testing.assert_array_equal(model.geom_group, groups)  # put back


def test_a_reflective_material_turns_culling_off():
    xml = SHADOWS.replace(
        "<worldbody>",
        '<asset><material name="mirror" reflectance="0.5"/></asset><worldbody>',
    ).replace('rgba="0.8 0.8 0.8 1"', 'material="mirror"')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    _, hidden, _ = frames(model, data, model.camera("down").id, (24, 32), cull=True)
    assert hidden == 0


@pytest.mark.parametrize("crop", [False, True])
def test_the_kit_frames_are_the_same_pixels_in_random_poses(crop):
    """Every camera of the kit, poses drawn across the joint ranges: culled frames equal the
    unculled ones pixel for pixel, and the wrist and cropped views leave geoms out."""
    model = mujoco.MjModel.from_xml_path(KIT)
    if crop:
        apply_crops(model, parse_crops(["cam_high:217,243,150,200"]))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    hinge = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    plain_r = mujoco.Renderer(model, 30, 40)
    cull_r = mujoco.Renderer(model, 30, 40)
    cull = ViewCull(model)
    hidden = {}
    try:
        for _ in range(6):
            mujoco.mj_resetData(model, data)
            for j in hinge:
                lo, hi = model.jnt_range[j]
                data.qpos[model.jnt_qposadr[j]] = rng.uniform(lo, hi)
            mujoco.mj_forward(model, data)
            for cam in range(model.ncam):
                plain_r.update_scene(data, camera=cam)
                n = cull.update_scene(cull_r, data, cam)
                hidden[cam] = hidden.get(cam, 0) + n
                np.testing.assert_array_equal(plain_r.render(), cull_r.render())
    finally:
        plain_r.close()
        cull_r.close()
    assert hidden[model.camera("cam_left_wrist").id] > 0
    if crop:
        assert hidden[model.camera("cam_high").id] > 0
