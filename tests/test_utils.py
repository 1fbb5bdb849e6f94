"""utils: sample_box_pose, make_sim_env (the documented helpers); assets.asset_path."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from dm_control.rl import control

from trossen_arm_mujoco import utils
from trossen_arm_mujoco.assets import asset_path
from trossen_arm_mujoco.constants import ASSETS_DIR, DT
from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.sim_env import TransferCubeTask
from trossen_arm_mujoco.utils import make_sim_env, sample_box_pose


def test_public_names():
    assert set(utils.__all__) == {"Quaternion", "make_sim_env", "sample_box_pose"}
    assert utils.Quaternion is Quaternion


def test_sample_box_pose_without_arguments():
    pose = sample_box_pose()
    assert pose.shape == (7,)
    assert -0.15 <= pose[0] <= 0.15 and -0.2 <= pose[1] <= 0.1
    assert pose[2] == pytest.approx(0.0325)
    np.testing.assert_array_equal(pose[3:], [1, 0, 0, 0])


def test_sample_box_pose_seeds_and_generators():
    np.testing.assert_array_equal(sample_box_pose(5), sample_box_pose(5))
    np.testing.assert_array_equal(
        sample_box_pose(np.random.default_rng(5)), sample_box_pose(np.random.default_rng(5))
    )
    np.testing.assert_array_equal(sample_box_pose(5), sample_box_pose(np.random.default_rng(5)))
    assert not np.array_equal(sample_box_pose(5), sample_box_pose(6))
    rng = np.random.default_rng(0)
    assert not np.array_equal(sample_box_pose(rng), sample_box_pose(rng))  # the stream advances


def test_asset_path():
    assert str(asset_path("wxai/wxai_follower.xml")) == os.path.join(
        ASSETS_DIR, "wxai/wxai_follower.xml"
    )
    absolute = str(Path("/tmp/some/scene.xml"))
    assert str(asset_path(absolute)) == absolute


def test_make_sim_env_returns_a_dm_control_environment():
    env = make_sim_env(TransferCubeTask, cam_list=[], random=0)
    assert isinstance(env, control.Environment)
    assert env.control_timestep() == pytest.approx(DT)
    ts = env.reset()
    assert ts.first() and ts.reward is None
    env.task.close()


def test_make_sim_env_default_scene_per_task():
    ee = make_sim_env(TransferCubeEETask, cam_list=[])
    joint = make_sim_env(TransferCubeTask, cam_list=[])
    assert ee.physics.model.nmocap == 2 and ee.physics.model.nu == 2
    assert joint.physics.model.nmocap == 0 and joint.physics.model.nu == 14


def test_make_sim_env_xml_file_override():
    joint_scene = os.path.join(ASSETS_DIR, "stationary_ai/trossen_ai_scene_joint.xml")
    env = make_sim_env(TransferCubeTask, joint_scene, cam_list=[])  # absolute path
    assert env.physics.model.nu == 14
    env = make_sim_env(TransferCubeTask, "stationary_ai/trossen_ai_scene_joint.xml", cam_list=[])
    assert env.physics.model.nu == 14


def test_make_sim_env_errors(tmp_path):
    with pytest.raises(
        UserError, match="unknown task 'sim_folding'; valid tasks: .*sim_insertion, sim_transfer"
    ):
        make_sim_env(TransferCubeTask, task_name="sim_folding")
    with pytest.raises(UserError, match="task_class must be a class"):
        make_sim_env(TransferCubeTask(), cam_list=[])
    with pytest.raises(UserError, match="model file not found"):
        make_sim_env(TransferCubeTask, str(tmp_path / "nope.xml"))


def test_make_sim_env_looks(fake_menagerie):
    env = make_sim_env(TransferCubeTask, cam_list=["cam_high"], image_size=(24, 32))
    assert env.physics.model.light_castshadow.sum() == 1  # the key light
    env = make_sim_env(
        TransferCubeTask,
        cam_list=["cam_high"],
        image_size=(24, 32),
        shadows=False,
        visual="menagerie",
    )
    model = env.physics.model
    assert not model.light_castshadow.any()
    assert "menagerie_link_2" in [model.mesh(i).name for i in range(model.nmesh)]
    assert env.reset().observation["images"]["cam_high"].std() > 0
    env.task.close()
    with pytest.raises(UserError, match="unknown visual 'pretty'"):
        make_sim_env(TransferCubeTask, cam_list=[], visual="pretty")


def test_time_limit():
    env = make_sim_env(TransferCubeTask, cam_list=[], time_limit=5 * DT)
    ts = env.reset()
    action = ts.observation["qpos"]
    steps = 0
    while not ts.last():
        ts = env.step(action)
        steps += 1
    assert steps == 5
    env.task.close()


def test_onscreen_render_is_accepted():
    env = make_sim_env(TransferCubeTask, onscreen_render=True, cam_list=[])
    assert env.task.onscreen_render is True


# --- domain randomization through make_sim_env -----------------------------------------------
def _scene_fields(env) -> dict[str, np.ndarray]:
    from trossen_arm_mujoco.tasks.randomization import FIELDS

    model = env.physics.model.ptr
    return {f: getattr(model, f).copy() for f in FIELDS}


def test_make_sim_env_randomize_off_by_default():
    env = make_sim_env(TransferCubeEETask, cam_list=[], random=0)
    env.reset()
    assert env.task.applied_randomization is None
    env.task.close()


def test_make_sim_env_randomize_same_seed_same_scene():
    kw = dict(cam_list=["cam_high"], image_size=(32, 40), randomize=True)
    a, b = (make_sim_env(TransferCubeEETask, random=7, **kw) for _ in range(2))
    c = make_sim_env(TransferCubeEETask, random=8, **kw)
    try:
        obs = [env.reset().observation for env in (a, b, c)]
        obs = [env.reset().observation for env in (a, b, c)]  # second episode of each
        rec = [env.task.applied_randomization for env in (a, b, c)]
        assert rec[0] == rec[1] != rec[2]
        np.testing.assert_array_equal(obs[0]["images"]["cam_high"], obs[1]["images"]["cam_high"])
        assert not np.array_equal(obs[0]["images"]["cam_high"], obs[2]["images"]["cam_high"])
        np.testing.assert_array_equal(obs[0]["qpos"], obs[1]["qpos"])
    finally:
        for env in (a, b, c):
            env.task.close()


def test_joint_env_replays_in_the_ee_env_scene():
    """The two phases of a recording: the joint env given the EE env's record and cube pose
    sees the same scene (model fields, initial joints, images)."""
    ee = make_sim_env(
        TransferCubeEETask, random=3, cam_list=["cam_high"], image_size=(32, 40), randomize=True
    )
    first = ee.reset().observation
    record = ee.task.applied_randomization
    joint = make_sim_env(
        TransferCubeTask,
        cam_list=["cam_high"],
        image_size=(32, 40),
        randomization=record,
        box_pose=first["env_state"],
    )
    try:
        replay = joint.reset().observation
        fields_ee, fields_joint = _scene_fields(ee), _scene_fields(joint)
        for name in ("light_dir", "light_diffuse", "cam_pos", "cam_quat"):
            np.testing.assert_array_equal(fields_ee[name], fields_joint[name])
        np.testing.assert_array_equal(first["qpos"], replay["qpos"])
        np.testing.assert_array_equal(first["env_state"], replay["env_state"])
        assert joint.task.applied_randomization == record
        np.testing.assert_array_equal(first["images"]["cam_high"], replay["images"]["cam_high"])
    finally:
        ee.task.close()
        joint.task.close()


def test_make_sim_env_randomize_needs_a_registered_task():
    from trossen_arm_mujoco.ee_sim_env import TrossenAIStationaryEETask

    with pytest.raises(UserError, match="randomize=True needs a registered task class"):
        make_sim_env(TrossenAIStationaryEETask, randomize=True)
