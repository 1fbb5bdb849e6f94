"""Rendering at the cost of its pixels: the finite floor, Mesa's threads for small images, the
antialias look, and frames that stay within the PSNR docs/benchmarks.md states."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from PIL import Image

from trossen_arm_mujoco.constants import ASSETS_DIR, STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.images import psnr
from trossen_arm_mujoco.sim.cameras import SMALL_IMAGE, CameraSet, render_threads
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.sim.scene import load_model

ASSETS = Path(ASSETS_DIR)
KIT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"
#: Frames of the kit at its home pose, 60x80, rendered by the commit before the floor and the
#: shadow map changed (docs/benchmarks.md, "Rendering cost").
BEFORE = Path(__file__).parents[1] / "fixtures" / "frames_before"
#: The least PSNR (dB) docs/benchmarks.md promises against those frames at 60x80.
MIN_PSNR = 35.0


def home(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return data


@pytest.mark.parametrize(
    "scene",
    sorted(p.relative_to(ASSETS).as_posix() for p in ASSETS.glob("*/scene*.xml"))
    + ["stationary_ai/trossen_ai.xml", "mobile_ai/mobile_ai.xml"],
)
def test_every_floor_is_finite_and_the_extent_is_pinned(scene):
    model = mujoco.MjModel.from_xml_path(str(ASSETS / scene))
    floors = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert floors, "every scene has a floor"
    for g in floors:
        assert model.geom_size[g][0] > 0 and model.geom_size[g][1] > 0
    spec = mujoco.MjSpec.from_file(str(ASSETS / scene))
    for g in spec.geoms:
        if g.type == mujoco.mjtGeom.mjGEOM_PLANE:
            g.size = [0, 0, 0.05]
    infinite = spec.compile()
    assert model.stat.extent == pytest.approx(infinite.stat.extent, rel=1e-4)
    np.testing.assert_allclose(model.stat.center, infinite.stat.center, atol=1e-4)


def test_render_threads_are_off_for_small_images_only(monkeypatch):
    monkeypatch.delenv("LP_NUM_THREADS", raising=False)
    assert render_threads(60, 80) == "0"
    assert render_threads(SMALL_IMAGE, SMALL_IMAGE) == "0"
    assert render_threads(480, 640) is None
    monkeypatch.setenv("LP_NUM_THREADS", "2")
    assert render_threads(60, 80) is None  # the user's setting wins


_CHILD = """
import json, os, sys
import mujoco
from trossen_arm_mujoco.sim.cameras import CameraSet
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model); mujoco.mj_forward(model, data)
cams = CameraSet(model, ["cam_high"], 60, 80)
image = cams.render(data, "cam_high")
tasks = len(os.listdir("/proc/self/task"))
cams.close()
print(json.dumps({"tasks": tasks, "env": os.environ.get("LP_NUM_THREADS"),
                  "image": image.tolist()}))
"""


def _render_in_child(threads: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    env["MUJOCO_GL"] = "egl"
    if threads is not None:
        env["LP_NUM_THREADS"] = threads
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, str(KIT)],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_small_first_renderer_starts_gl_without_raster_threads_and_draws_the_same():
    auto = _render_in_child(None)
    threaded = _render_in_child("2")
    assert auto["env"] is None  # the variable is not left behind for child processes
    assert threaded["env"] == "2"
    assert auto["tasks"] < threaded["tasks"]  # Mesa started no rasterizer thread
    assert auto["image"] == threaded["image"]  # the same pixels either way


def test_the_antialias_look_is_checked_and_applied():
    with pytest.raises(UserError, match="antialias must be True or False") as err:
        SceneLooks(antialias="no")
    assert "\n" not in str(err.value)
    smooth = load_model(KIT)
    plain = load_model(KIT, SceneLooks(antialias=False))
    assert smooth.vis.quality.offsamples > 0 and plain.vis.quality.offsamples == 0
    images = []
    for model in (smooth, plain):
        cams = CameraSet(model, ["cam_high"], 60, 80)
        images.append(cams.render(home(model), "cam_high"))
        cams.close()
    assert not np.array_equal(*images)  # the look changes what it says


def test_frames_stay_within_the_stated_psnr_of_the_frames_before():
    model = load_model(KIT)
    cams = CameraSet(model, STATIONARY_CAMERAS, 60, 80)
    try:
        frames = cams.render_all(home(model))
    finally:
        cams.close()
    for name, image in frames.items():
        before = np.asarray(Image.open(BEFORE / f"stationary_ai_{name}_60x80.png"))
        assert psnr(image, before) >= MIN_PSNR, name


def test_the_gym_envs_take_the_antialias_look():
    from trossen_arm_mujoco.gym.env import TrossenMujocoEnv

    env = TrossenMujocoEnv("push", obs_type="pixels", width=16, height=12, antialias=False)
    try:
        assert env.scene.model.vis.quality.offsamples == 0
        obs, _ = env.reset(seed=0)
        assert np.asarray(obs["pixels"] if isinstance(obs, dict) else obs).std() > 0
    finally:
        env.close()
    with pytest.raises(UserError, match="antialias must be True or False"):
        TrossenMujocoEnv("push", antialias=1)
