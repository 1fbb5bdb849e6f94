"""Scene lighting: one shadow-casting key light, fills without shadows, and a table that
renders at about its own colour (not washed out to white), with shadows on and off."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.sim.cameras import shadow_map_size

ASSETS = Path(ASSETS_DIR)
#: scene -> (main camera, table geom drawn)
SCENES = {
    "wxai/scene_reach.xml": ("overview", "table"),
    "wxai/scene_push.xml": ("overview", "table"),
    "wxai/scene_pick_place.xml": ("overview", "table"),
    "stationary_ai/trossen_ai_scene.xml": ("cam_high", "table_visual"),
    "stationary_ai/trossen_ai_scene_joint.xml": ("cam_high", "table_visual"),
    "stationary_ai/trossen_ai_insertion_scene.xml": ("cam_high", "table_visual"),
    "stationary_ai/trossen_ai_insertion_scene_joint.xml": ("cam_high", "table_visual"),
}
H, W = 60, 80
LUMA = np.array([0.2126, 0.7152, 0.0722])
# The table is maple (texture colour about (0.80, 0.64, 0.45), luminance 0.67 -> 170 of 255),
# like the light wood top of the real kit. Lit at 100% it renders at its own colour. MuJoCo
# clamps the sum of the lights drawn together at 1 but adds every shadow-casting light in an
# extra pass on top, so a second full-strength shadow light washed the table out to white
# (mean luminance 246, 95% of its pixels with a channel >= 250, before this change).
# A table brighter than its own colour, or with more than 1% of its pixels saturated, fails;
# so does one darker than 60% of it (a scene too dim to see).
TABLE_MAX_LUMA = 175.0
TABLE_MIN_LUMA = 100.0
MAX_SATURATED = 0.01


def render_table(model: mujoco.MjModel, camera: str, table: str):
    """(image with shadows, image without, mask of the table's pixels), (H, W[, 3]), at the
    home keyframe; the shadow map is the one the package's cameras use at this size."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    model.vis.quality.shadowsize = shadow_map_size(model.vis.quality.shadowsize, H, W)
    images = []
    with mujoco.Renderer(model, H, W) as renderer:
        for shadows in (model.light_castshadow.copy(), 0):
            model.light_castshadow[:] = shadows
            renderer.update_scene(data, camera)
            images.append(renderer.render())
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, camera)
        seg = renderer.render()
    gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, table)
    mask = (seg[..., 0] == gid) & (seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM)
    return images[0], images[1], mask


@pytest.mark.parametrize("scene", SCENES)
def test_one_shadow_casting_key_light_and_fills(scene):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / scene))
    lights = [model.light(i).name for i in range(model.nlight)]
    assert lights[0] == "key" and len(lights) >= 2
    assert model.light_castshadow.tolist() == [True] + [False] * (len(lights) - 1)
    # the fills are weaker than the key
    assert np.all(model.light_diffuse[1:].max(axis=1) < model.light_diffuse[0].min())


def test_the_arm_model_brings_no_lights():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    assert model.nlight == 0


@pytest.mark.parametrize("scene", SCENES)
def test_table_is_not_washed_out_with_or_without_shadows(scene):
    camera, table = SCENES[scene]
    model = mujoco.MjModel.from_xml_path(str(ASSETS / scene))
    lit, flat, mask = render_table(model, camera, table)
    assert mask.mean() > 0.1, "the table should fill part of the main camera's view"
    for image in (lit, flat):
        pixels = image[mask].astype(float)
        luma = pixels @ LUMA
        assert TABLE_MIN_LUMA < luma.mean() < TABLE_MAX_LUMA, luma.mean()
        assert (pixels.max(axis=1) >= 250).mean() < MAX_SATURATED
    # with shadows, part of the table lies in a shadow (of the arm or the kit's frame)
    shade = (lit[mask].astype(float) @ LUMA) < 0.8 * (flat[mask].astype(float) @ LUMA)
    assert shade.mean() > 0.005
