"""Two-phase recording: schema, determinism, replay fidelity."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import (
    EpisodeRecorder,
    RecordSettings,
    episode_seed,
    policy_minimum_episode_len,
)
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.sim_env import TransferCubeTask
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.utils import make_sim_env

CAMS = ("cam_high", "cam_left_wrist")


@pytest.fixture(scope="module")
def recorder():
    rec = EpisodeRecorder(RecordSettings(episode_len=40, cam_names=CAMS, height=24, width=32))
    yield rec
    rec.close()


@pytest.fixture(scope="module")
def episode_file(recorder, tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "episode_0.hdf5"
    recorder.record(0, path)
    return path


def test_episode_matches_documented_layout(episode_file):
    import h5py

    with h5py.File(episode_file, "r") as f:
        assert bool(f.attrs["sim"]) is True
        assert f["observations/qpos"].shape == (40, 16)
        # float32 like the vendor files (schema version 2), images gzip by default
        assert f.attrs["schema_version"] == 2
        assert f["observations/qpos"].dtype == np.float32
        assert f["observations/qvel"].dtype == np.float32
        assert f["action"].shape == (40, 16) and f["action"].dtype == np.float32
        assert f["reward"].shape == (40,) and f["reward"].dtype == np.float32
        assert f["observations/env_state"].shape == (40, 7)
        assert f["observations/env_state"].dtype == np.float32
        for cam in CAMS:
            ds = f[f"observations/images/{cam}"]
            assert ds.shape == (40, 24, 32, 3) and ds.dtype == np.uint8
            assert ds.chunks == (1, 24, 32, 3)
            assert ds.compression == "gzip"
        assert set(f["observations/images"]) == set(CAMS)
        for key in (
            "task_name",
            "seed",
            "success",
            "episode_len",
            "dt",
            "camera_names",
            "box_pose",
            "package_version",
            "mujoco_version",
            "schema_version",
        ):
            assert key in f.attrs, key


def test_images_are_real_renders(episode_file):
    ep = load_episode(episode_file, load_images=True)
    img = ep.images["cam_high"]
    assert img.std() > 5  # not blank
    assert not np.array_equal(img[0], np.zeros_like(img[0]))


def test_same_seed_same_episode(recorder, episode_file, tmp_path):
    again = tmp_path / "episode_0.hdf5"
    recorder.record(0, again)
    a, b = load_episode(episode_file, load_images=True), load_episode(again, load_images=True)
    for name in ("qpos", "qvel", "action", "reward", "env_state"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for cam in CAMS:
        np.testing.assert_array_equal(a.images[cam], b.images[cam])
    assert a.attrs == b.attrs or {k: str(v) for k, v in a.attrs.items()} == {
        k: str(v) for k, v in b.attrs.items()
    }


def test_different_attempts_differ():
    assert episode_seed(0, 0) != episode_seed(0, 1)
    assert episode_seed(0, 1) != episode_seed(1, 1)
    assert episode_seed(3, 7) == episode_seed(3, 7)


def test_replaying_actions_reproduces_qpos(episode_file):
    """The stored (float32) actions are exactly the replayed ones: replaying them gives the
    stored qpos to the last float32 bit."""
    ep = load_episode(episode_file)
    env = make_sim_env(TransferCubeTask, cam_list=[], box_pose=ep.attrs["box_pose"])
    ts = env.reset()
    qpos = []
    for action in ep.action:
        qpos.append(ts.observation["qpos"])
        ts = env.step(action)
    np.testing.assert_array_equal(np.array(qpos, dtype=np.float32), ep.qpos)
    env.task.close()


def test_full_episode_succeeds_without_images():
    rec = EpisodeRecorder(RecordSettings(episode_len=600))
    try:
        rng = np.random.default_rng(episode_seed(0, 0))
        actions, box = rec.scripted_rollout(rng)
        rewards = rec.replay(actions, box)
    finally:
        rec.close()
    assert rewards[-1] == 4
    assert actions.shape == (600, 16)
    low, high = rec.action_low, rec.action_high
    assert np.all(actions >= low) and np.all(actions <= high)
    # ... and the real-arm replay validation accepts them at the default 10 Hz
    from trossen_arm_mujoco.real.validate import ArmLimits, validate_actions

    validate_actions(actions, 10.0, ArmLimits.from_mjcf())
    # gripper columns carry the commanded values, equal within each gripper
    np.testing.assert_array_equal(actions[:, 6], actions[:, 7])
    np.testing.assert_array_equal(actions[:, 14], actions[:, 15])


# --- domain randomization --------------------------------------------------------------------
SMALL = dict(episode_len=10, cam_names=("cam_high",), height=24, width=32)


def _record(tmp_path, name: str, attempt: int = 0, **settings):
    recorder = EpisodeRecorder(RecordSettings(**{**SMALL, **settings}))
    try:
        path = tmp_path / name / f"episode_{attempt}.hdf5"
        recorder.record(attempt, path)
    finally:
        recorder.close()
    return path


def test_default_recording_is_bit_identical_to_one_without_randomization(tmp_path, monkeypatch):
    """Off by default: the file equals, byte for byte, one recorded with every
    randomization code path of the samplers removed."""
    from trossen_arm_mujoco.tasks.sampler import TaskSampler

    default = _record(tmp_path, "default")
    monkeypatch.setattr(TaskSampler, "_make_randomizer", lambda self: None)
    monkeypatch.setattr(TaskSampler, "randomize_scene", lambda self, env, view: None)
    bare = _record(tmp_path, "bare")
    assert default.read_bytes() == bare.read_bytes()
    assert "randomization" not in load_episode(default).attrs


def test_randomized_recording_stores_its_record_and_is_reproducible(tmp_path):
    from trossen_arm_mujoco.tasks.randomization_record import KINDS, record_from_json

    a = _record(tmp_path, "a", randomize=True)
    b = _record(tmp_path, "b", randomize=True)
    c = _record(tmp_path, "c", attempt=1, randomize=True)
    plain = _record(tmp_path, "plain")
    assert a.read_bytes() == b.read_bytes()
    rec_a = record_from_json(load_episode(a).attrs["randomization"])
    rec_c = record_from_json(load_episode(c).attrs["randomization"])
    assert set(rec_a) == {"version", "seed", *KINDS} and rec_a != rec_c
    ep, ep_plain = load_episode(a), load_episode(plain)
    # same seed, same task episode: the cube starts where it starts without randomization
    np.testing.assert_array_equal(
        ep.attrs["initial_env_state"], ep_plain.attrs["initial_env_state"]
    )
    with ep.open_frames() as fa, ep_plain.open_frames() as fp:
        assert not np.array_equal(fa.read("cam_high", 0), fp.read("cam_high", 0))


#: kind of a record -> (model accessor, attributes compared between the two flavours)
_COMPARED = {
    "lights": ("light", ("dir", "diffuse", "specular", "ambient")),
    "table": ("geom", ("rgba", "matid")),
    "objects": ("geom", ("rgba",)),
    "friction": ("geom", ("friction",)),
    "object_mass": ("body", ("mass", "inertia")),
    "camera": ("cam", ("pos", "quat")),
}


def test_both_phases_see_the_same_randomized_scene():
    recorder = EpisodeRecorder(RecordSettings(**{**SMALL, "randomize": True}))
    try:
        actions, poses = recorder.scripted_rollout(np.random.default_rng(5))
        record = recorder.last_randomization
        recorder.replay(actions[:1], poses)
        assert recorder.joint_sampler.randomization == record
        ee, joint = recorder.ee_scene.model, recorder.joint_scene.model
        for kind, (obj, attrs) in _COMPARED.items():
            assert record[kind]
            for name in record[kind]:
                a, b = getattr(ee, obj)(name), getattr(joint, obj)(name)
                for attr in attrs:
                    np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr))
        for name in record["joint_damping"]:
            da, db = ee.joint(name).dofadr[0], joint.joint(name).dofadr[0]
            assert ee.dof_damping[da] == joint.dof_damping[db] != 0.0
        # initial joints: phase 1's start (sampled again) equals phase 2's start
        recorder.ee_sampler.sample_task(np.random.default_rng(5))
        recorder.joint_sampler.sample_task(0, object_poses=poses, randomization=record)
        ee_data, joint_data = recorder.ee_scene.data, recorder.joint_scene.data
        for name, v in record["joint_noise"].items():
            q_ee = ee_data.qpos[ee.joint(name).qposadr[0]]
            q_joint = joint_data.qpos[joint.joint(name).qposadr[0]]
            assert q_ee == q_joint == v["qpos"]
    finally:
        recorder.close()


def test_stored_record_re_renders_the_episode_exactly(tmp_path):
    from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT
    from trossen_arm_mujoco.tasks import registry
    from trossen_arm_mujoco.tasks.randomization_record import record_from_json

    path = _record(tmp_path, "ep", randomize=True)
    ep = load_episode(path)
    record = record_from_json(ep.attrs["randomization"])
    names = list(ep.attrs["object_names"])
    poses = dict(zip(names, np.asarray(ep.attrs["initial_env_state"]).reshape(-1, 7)))
    sampler = registry.make_sampler(
        "sim_transfer_cube", SamplerSettings(camera_names=["cam_high"], height=24, width=32)
    )
    try:
        task = sampler.sample_task(0, object_poses=poses, randomization=record)
        with ep.open_frames() as frames:
            for t in range(len(ep.action)):
                qpos = task.get_observation()["qpos"].astype(np.float32)  # as stored
                np.testing.assert_array_equal(qpos, ep.qpos[t].astype(np.float32))
                image = sampler.scene.render_images()["cam_high"]
                np.testing.assert_array_equal(image, frames.read("cam_high", t))
                task.step(VENDOR16_LAYOUT.joint_commands(ep.action[t]))
    finally:
        sampler.close()


def test_minimum_episode_len_comes_from_the_scripted_policy(recorder):
    from trossen_arm_mujoco.policies.insertion import InsertionPolicy
    from trossen_arm_mujoco.policies.transfer_cube import PickAndTransferPolicy

    assert policy_minimum_episode_len("sim_transfer_cube") == 440
    assert PickAndTransferPolicy.minimum_episode_len == 440
    assert policy_minimum_episode_len("sim_insertion") == InsertionPolicy.minimum_episode_len
    assert recorder.minimum_episode_len == 440
