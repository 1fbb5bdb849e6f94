"""Scene: loading, timing ratios, reset to the keyframe and robot init, stepping."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from dm_control import mujoco as dm_mujoco

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config, wxai_config
from trossen_arm_mujoco.sim.scene import Scene, load_physics, whole_ratio

ASSETS = Path(ASSETS_DIR)
WXAI = ASSETS / "wxai/wxai_follower.xml"
KIT_JOINT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"


def test_whole_ratio():
    assert whole_ratio(0.02, 0.002, "ctrl_dt", "sim_dt") == 10
    assert whole_ratio(0.002, 0.002, "ctrl_dt", "sim_dt") == 1
    with pytest.raises(UserError, match=r"ctrl_dt \(0.005 s\) must be a whole multiple of sim_dt"):
        whole_ratio(0.005, 0.002, "ctrl_dt", "sim_dt")
    with pytest.raises(UserError, match="whole multiple"):
        whole_ratio(0.001, 0.002, "ctrl_dt", "sim_dt")  # shorter than one physics step
    with pytest.raises(UserError, match="must be positive"):
        whole_ratio(0.0, 0.002, "ctrl_dt", "sim_dt")


def test_load_physics_errors(tmp_path):
    with pytest.raises(UserError, match="model file not found"):
        load_physics(tmp_path / "missing.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(UserError, match="cannot load model") as err:
        load_physics(broken)
    assert "\n" not in str(err.value)  # one line
    physics = load_physics(WXAI)
    assert isinstance(physics, dm_mujoco.Physics)


def test_scene_needs_a_model():
    with pytest.raises(UserError, match="xml_path or a physics"):
        Scene()


def test_ctrl_dt_must_be_whole_multiple():
    with pytest.raises(UserError, match="whole multiple"):
        Scene(WXAI, ctrl_dt=0.003)
    scene = Scene(WXAI)
    assert scene.ctrl_dt == scene.sim_dt == 0.002 and scene.n_substeps == 1


def test_reset_and_step_single_arm():
    scene = Scene(WXAI, robots={"wxai": wxai_config()}, ctrl_dt=0.02)
    assert scene.n_substeps == 10
    scene.data.qpos[:] = 1.0  # garbage
    scene.data.time = 5.0
    scene.reset()
    assert scene.data.time == 0.0
    np.testing.assert_allclose(scene.data.qpos, START_ARM_POSE[:8])
    scene.step(5)
    assert scene.data.time == pytest.approx(5 * 0.02)
    np.testing.assert_allclose(scene.data.qpos, START_ARM_POSE[:8], atol=1e-3)  # held
    assert scene.warnings() == []
    scene.close()


def test_reset_without_keyframe_uses_model_defaults():
    scene = Scene(WXAI, keyframe="no_such_key")
    assert scene.keyframe_id == -1
    scene.data.qpos[:] = 0.5
    scene.reset()
    np.testing.assert_array_equal(scene.data.qpos, scene.model.qpos0)


def test_scene_over_an_existing_physics_shares_its_data():
    physics = load_physics(KIT_JOINT)
    scene = Scene(
        physics=physics,
        robots={"kit": stationary_ai_joint_config()},
        objects={"box": ("red_box_joint", "red_box")},
        ctrl_dt=0.02,
    )
    assert scene.model is physics.model.ptr and scene.data is physics.data.ptr
    scene.reset()
    np.testing.assert_allclose(physics.data.qpos[:16], START_ARM_POSE)
    scene.objects["box"].set_pose(scene.data, [0.05, -0.05, 0.0325, 1, 0, 0, 0])
    scene.forward()
    np.testing.assert_allclose(physics.named.data.qpos["red_box_joint"][:2], [0.05, -0.05])
    scene.step(25)
    np.testing.assert_allclose(
        scene.objects["box"].get_pose(scene.data)[:3], [0.05, -0.05, 0.0325], atol=1e-3
    )


def test_apply_control_does_not_step():
    scene = Scene(KIT_JOINT, robots={"kit": stationary_ai_joint_config()}, ctrl_dt=0.02)
    scene.reset()
    robot = scene.robots["kit"]
    target = scene.data.qpos[:6] + 0.05  # within one tick's reach (3.375 rad/s * 0.02 s)
    robot.update_control({"left_arm": target})
    t0, q0 = scene.data.time, scene.data.qpos.copy()
    scene.apply_control()
    assert scene.data.time == t0
    np.testing.assert_array_equal(scene.data.qpos, q0)
    np.testing.assert_allclose(scene.data.ctrl[:6], target)


def test_warnings_are_reported_by_name():
    scene = Scene(WXAI)
    scene.reset()
    assert scene.warnings() == []
    scene.data.qpos[0] = np.nan
    mujoco.mj_step(scene.model, scene.data)
    assert "mjWARN_BADQPOS" in scene.warnings()


def test_rendering_through_the_scene():
    scene = Scene(KIT_JOINT, camera_names=["cam_high"], height=24, width=32)
    scene.reset()
    images = scene.render_images()
    assert list(images) == ["cam_high"]
    assert images["cam_high"].shape == (24, 32, 3) and images["cam_high"].dtype == np.uint8
    scene.close()
    scene.close()  # idempotent


def _arm_moves(scene: Scene) -> np.ndarray:
    scene.reset()
    scene.objects["box"].set_pose(scene.data, [0.05, -0.05, 0.0325, 1, 0, 0, 0])
    scene.forward()
    scene.robots["kit"].update_control({"left_arm": scene.data.qpos[:6] + 0.3})
    scene.step(30)
    return scene.data.qpos.copy()


def test_scene_without_physics_runs_on_plain_mujoco_and_matches_dm_control():
    """Without a Physics the scene owns a plain MjModel/MjData and steps with mj_step; the
    trajectory is bit for bit the one of the same scene over a dm_control Physics."""
    kwargs = dict(
        robots={"kit": stationary_ai_joint_config()},
        objects={"box": ("red_box_joint", "red_box")},
        ctrl_dt=0.02,
    )
    plain = Scene(KIT_JOINT, **kwargs)
    assert plain.physics is None
    assert isinstance(plain.model, mujoco.MjModel) and isinstance(plain.data, mujoco.MjData)
    over_physics = Scene(physics=load_physics(KIT_JOINT), **kwargs)
    np.testing.assert_array_equal(_arm_moves(plain), _arm_moves(over_physics))


def test_scene_over_a_model_and_data():
    model = mujoco.MjModel.from_xml_path(str(WXAI))
    data = mujoco.MjData(model)
    scene = Scene(model=model, data=data, robots={"wxai": wxai_config()}, ctrl_dt=0.02)
    assert scene.model is model and scene.data is data and scene.physics is None
    scene.reset()
    scene.step(3)
    assert data.time == pytest.approx(0.06)
    assert Scene(model=model).data is not data  # a new MjData when none is given


def test_load_model_errors(tmp_path):
    from trossen_arm_mujoco.sim.scene import load_model

    with pytest.raises(UserError, match="model file not found"):
        load_model(tmp_path / "missing.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(UserError, match="cannot load model") as err:
        load_model(broken)
    assert "\n" not in str(err.value)
    with pytest.raises(UserError, match="cannot load model"):
        Scene(broken)


def test_one_stepping_loop_control_then_physics():
    """step(n): n control ticks, each the robots' control and then ctrl_dt / sim_dt
    physics steps; nothing else advances time."""
    scene = Scene(WXAI, robots={"wxai": wxai_config()}, ctrl_dt=0.01)
    scene.reset()
    calls = []
    scene.robots["wxai"].apply_control = lambda data: calls.append(("control", data.time))
    physics = scene._physics_step
    scene._physics_step = lambda n: (calls.append(("physics", n)), physics(n))
    scene.step(3)
    assert [c[0] for c in calls] == ["control", "physics"] * 3
    assert all(n == 5 for kind, n in calls if kind == "physics")
    assert [t for kind, t in calls if kind == "control"] == pytest.approx([0.0, 0.01, 0.02])


def test_cameras_open_no_renderer_until_an_image_is_asked_for():
    scene = Scene(KIT_JOINT, camera_names=["cam_high"], height=24, width=32)
    scene.reset()
    scene.step(2)
    assert scene.cameras._renderer is None
    scene.render_images()
    assert scene.cameras._renderer is not None
    scene.close()


def test_reset_without_settling_sets_positions_and_leaves_the_controls():
    """reset(settle=False) (the samplers' reset): the same joints and body positions as a
    full reset, the keyframe's controls, commands dropped; hold() then gives the full reset's
    controls."""
    full = Scene(KIT_JOINT, robots={"kit": stationary_ai_joint_config()}, ctrl_dt=0.02)
    part = Scene(KIT_JOINT, robots={"kit": stationary_ai_joint_config()}, ctrl_dt=0.02)
    for scene in (full, part):
        scene.data.qpos[:] += 0.05  # somewhere else first
        scene.data.ctrl[:] = 0.3
        scene.robots["kit"].update_control({"left_arm": np.zeros(6)})
    full.reset()
    part.reset(settle=False)
    np.testing.assert_array_equal(part.data.qpos, full.data.qpos)
    np.testing.assert_array_equal(part.data.xpos, full.data.xpos)
    keyframe = part.model.key_ctrl[part.keyframe_id]
    np.testing.assert_array_equal(part.data.ctrl, keyframe)
    assert not part.robots["kit"]._commands
    part.robots["kit"].hold(part.data)
    np.testing.assert_array_equal(part.data.ctrl, full.data.ctrl)
