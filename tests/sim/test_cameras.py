"""CameraSet: names checked at construction, tiny renders, one renderer reused, close()."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR, STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.cameras import CameraSet

ASSETS = Path(ASSETS_DIR)
H, W = 36, 48


@pytest.fixture(scope="module")
def kit():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


def test_available_cameras(kit):
    model, _ = kit
    assert CameraSet.available(model) == list(STATIONARY_CAMERAS)


def test_unknown_camera_lists_valid_names(kit):
    model, _ = kit
    with pytest.raises(UserError) as err:
        CameraSet(model, ["cam_high", "top"], H, W)
    assert "unknown camera 'top'" in str(err.value)
    assert "cam_left_wrist" in str(err.value)


def test_bad_sizes(kit):
    model, _ = kit
    with pytest.raises(UserError, match="must be positive"):
        CameraSet(model, ["cam_high"], 0, W)
    with pytest.raises(UserError, match="exceeds the model's offscreen buffer 480x640"):
        CameraSet(model, ["cam_high"], 720, 1280)


def test_render_all_tiny_images(kit):
    model, data = kit
    cams = CameraSet(model, STATIONARY_CAMERAS, H, W)
    try:
        images = cams.render_all(data)
        assert list(images) == list(STATIONARY_CAMERAS)
        for name, img in images.items():
            assert img.shape == (H, W, 3) and img.dtype == np.uint8, name
            assert img.std() > 5, f"{name} looks blank"
        # the cameras look at different things
        assert not np.array_equal(images["cam_high"], images["cam_low"])
        assert not np.array_equal(images["cam_left_wrist"], images["cam_right_wrist"])
    finally:
        cams.close()


def test_renderer_is_reused_and_closed(kit):
    model, data = kit
    cams = CameraSet(model, ["cam_high"], H, W)
    assert cams._renderer is None  # nothing is created before the first render
    first = cams.render(data, "cam_high")
    renderer = cams._renderer
    second = cams.render(data, "cam_high")
    assert cams._renderer is renderer
    np.testing.assert_array_equal(first, second)  # same state, same image
    cams.close()
    assert cams._renderer is None
    cams.close()  # idempotent
    again = cams.render(data, "cam_high")  # renders again after close
    np.testing.assert_array_equal(again, first)
    cams.close()


def test_render_only_configured_cameras(kit):
    model, data = kit
    cams = CameraSet(model, ["cam_low"], H, W)
    with pytest.raises(UserError, match="unknown camera 'cam_high'; valid cameras: cam_low"):
        cams.render(data, "cam_high")
    cams.close()


def test_wrist_camera_moves_with_the_arm(kit):
    model, _ = kit
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    wrist, high = model.camera("cam_left_wrist").id, model.camera("cam_high").id
    cam_pos = data.cam_xpos.copy()
    cams = CameraSet(model, ["cam_left_wrist"], H, W)
    try:
        before = cams.render(data, "cam_left_wrist")
        data.qpos[0] = 0.6  # turn the left arm's base joint
        mujoco.mj_forward(model, data)
        after = cams.render(data, "cam_left_wrist")
        assert np.abs(after.astype(int) - before).mean() > 5
    finally:
        cams.close()
    assert np.linalg.norm(data.cam_xpos[wrist] - cam_pos[wrist]) > 0.05
    np.testing.assert_array_equal(data.cam_xpos[high], cam_pos[high])  # fixed to the frame


def test_forked_child_of_a_rendering_process_cannot_render(kit, monkeypatch):
    """In a process forked from one with a GL context, rendering would hang: the first
    render fails at once with a one-line error naming the fix."""
    from trossen_arm_mujoco.sim import cameras as cameras_module

    model, data = kit
    monkeypatch.setattr(cameras_module, "_forked_from_gl", True)
    cams = CameraSet(model, ["cam_high"], H, W)
    with pytest.raises(UserError, match='context="spawn"') as err:
        cams.render(data, "cam_high")
    assert "\n" not in str(err.value) and cams._renderer is None
    with pytest.raises(UserError, match="forked"):
        cameras_module.check_can_render()
    monkeypatch.setattr(cameras_module, "_forked_from_gl", False)
    cameras_module.check_can_render()  # nothing to say in a fresh process


def test_gl_opened_after_a_render(kit):
    from trossen_arm_mujoco.sim import cameras as cameras_module

    model, data = kit
    cams = CameraSet(model, ["cam_high"], H, W)
    cams.render(data, "cam_high")
    assert cameras_module.gl_opened()
    cams.close()


def run_python(code: str):
    import os
    import subprocess
    import sys

    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env
    )


def test_unclosed_renderer_exits_cleanly():
    """A renderer never closed is closed at exit, before MuJoCo terminates its EGL display
    (no 'Exception ignored ... EGLError' noise at interpreter shutdown)."""
    proc = run_python(
        "import gymnasium as gym\n"
        "import trossen_arm_mujoco\n"
        "env = gym.make('TrossenMujoco/WXAIReach-v0', obs_type='pixels', width=32, height=24)\n"
        "print(env.reset(seed=0)[0].shape)\n"  # and no env.close()
        "env = gym.make('TrossenMujoco/WXAIPush-v0', render_mode='rgb_array', width=32,\n"
        "               height=24, shadows=False)\n"
        "env.reset(seed=0)\n"
        "print(env.render().shape)\n"  # and no env.close()
    )
    assert proc.returncode == 0, proc.stderr
    assert "(24, 32, 3)" in proc.stdout
    assert "Exception ignored" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


def test_unclosed_dm_control_env_exits_cleanly():
    """Also when dm_control's own renderer opened (and registered its EGL termination)
    after the package's cameras."""
    proc = run_python(
        "from trossen_arm_mujoco.sim_env import TransferCubeTask\n"
        "from trossen_arm_mujoco.utils import make_sim_env\n"
        "env = make_sim_env(TransferCubeTask, cam_list=['cam_high'], image_size=(24, 32))\n"
        "print(env.reset().observation['images']['cam_high'].shape)\n"
        "print(env.physics.render(24, 32, camera_id=0).shape)\n"  # and no close
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("(24, 32, 3)") == 2
    assert "Exception ignored" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


@pytest.mark.parametrize(
    "size, expected",
    [
        ((480, 640), 2048),
        ((240, 320), 1024),
        ((128, 128), 512),
        ((24, 32), 256),
        ((960, 1280), 2048),
    ],
)
def test_shadow_map_follows_the_image_size(size, expected):
    from trossen_arm_mujoco.sim.cameras import shadow_map_size

    assert shadow_map_size(2048, *size) == expected


def test_renderer_gets_a_smaller_shadow_map_and_the_model_keeps_its_own(kit):
    model, data = kit
    full = model.vis.quality.shadowsize
    cams = CameraSet(model, ["cam_high"], H, W)
    cams.render(data, "cam_high")
    assert cams._renderer._mjr_context.shadowSize < full
    assert model.vis.quality.shadowsize == full
    cams.close()
