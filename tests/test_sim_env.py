"""The joint-position env: user-written tasks, seeded resets, BOX_POSE hand-over."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco import sim_env
from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.sim_env import BOX_POSE, TransferCubeTask, TrossenAIStationaryTask
from trossen_arm_mujoco.utils import make_sim_env, sample_box_pose

REST_Z = 0.0325


# --- a custom task written exactly the way the docs tell users to ------------------------
class MyJointTask(TrossenAIStationaryTask):
    def __init__(self, random=None, **kwargs):
        super().__init__(random=random, **kwargs)
        self.max_reward = 4

    def initialize_episode(self, physics):
        with physics.reset_context():
            physics.named.data.qpos[:16] = START_ARM_POSE
            np.copyto(physics.data.ctrl, np.zeros(14))
            physics.named.data.qpos[-7:] = sample_box_pose()
        super().initialize_episode(physics)

    @staticmethod
    def get_env_state(physics):
        env_state = physics.data.qpos.copy()[16:]
        return env_state

    def get_reward(self, physics):
        all_contact_pairs = []
        for i_contact in range(physics.data.ncon):
            id_geom_1 = physics.data.contact[i_contact].geom1
            id_geom_2 = physics.data.contact[i_contact].geom2
            name_geom_1 = physics.model.id2name(id_geom_1, "geom")
            name_geom_2 = physics.model.id2name(id_geom_2, "geom")
            contact_pair = (name_geom_1, name_geom_2)
            all_contact_pairs.append(contact_pair)

        touch_left_gripper = ("red_box", "left/gripper_follower_left") in all_contact_pairs
        touch_right_gripper = ("red_box", "right/gripper_follower_left") in all_contact_pairs
        touch_table = ("red_box", "table") in all_contact_pairs

        reward = 0
        if touch_right_gripper:
            reward = 1
        if touch_right_gripper and not touch_table:
            reward = 2
        if touch_left_gripper:
            reward = 3
        if touch_left_gripper and not touch_table:
            reward = 4
        return reward


@pytest.fixture(autouse=True)
def _clear_box_pose():
    """BOX_POSE is module state shared with other tests: leave it as found."""
    saved = BOX_POSE[0]
    BOX_POSE[0] = None
    yield
    BOX_POSE[0] = saved


def test_custom_task_runs_unchanged_for_100_steps():
    env = make_sim_env(MyJointTask, cam_list=[])
    ts = env.reset()
    np.testing.assert_allclose(ts.observation["qpos"], START_ARM_POSE)
    cube = ts.observation["env_state"]
    assert cube.shape == (7,) and cube[2] == pytest.approx(REST_Z)
    # initialize_episode of the base holds the state the user set, whatever ctrl they wrote
    np.testing.assert_allclose(env.physics.data.ctrl[:6], START_ARM_POSE[:6])
    action = np.array(START_ARM_POSE)
    rewards = []
    for _ in range(100):
        ts = env.step(action)
        rewards.append(ts.reward)
    assert rewards == [0] * 100
    np.testing.assert_allclose(ts.observation["qpos"], START_ARM_POSE, atol=1e-3)
    np.testing.assert_allclose(ts.observation["env_state"][:3], cube[:3], atol=2e-3)
    env.task.close()


def test_custom_task_reward_sees_contacts():
    """Cube between the right fingers, off the table: the user's scan gives 2."""
    env = make_sim_env(MyJointTask, cam_list=[])
    env.reset()
    physics = env.physics
    tool = env.task.robot(physics).view.get_move_group("right_arm").get_frame_pose(physics.data.ptr)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, tool[3:])
    center = tool[:3] - 0.025 * rot.reshape(3, 3)[:, 0]
    with physics.reset_context():
        physics.named.data.qpos[:16] = START_ARM_POSE
        physics.data.qpos[14:16] = 0.0124
        physics.named.data.qpos[-7:] = [*center, *tool[3:]]
    assert env.task.get_reward(physics) == 2
    env.task.close()


def seeded_rollout(seed: int, steps: int = 100):
    env = make_sim_env(TransferCubeTask, cam_list=[], random=seed)
    try:
        ts = env.reset()
        first = {k: np.copy(v) for k, v in ts.observation.items() if k != "images"}
        physics = env.physics
        qpos0 = physics.data.qpos.copy()
        action = np.array(START_ARM_POSE)
        max_arm_move = max_cube_xy = max_cube_dz = 0.0
        for _ in range(steps):
            ts = env.step(action)
            q = physics.data.qpos
            assert np.all(np.isfinite(q)) and np.all(np.isfinite(physics.data.qvel))
            max_arm_move = max(max_arm_move, np.abs(q[:16] - qpos0[:16]).max())
            max_cube_xy = max(max_cube_xy, np.abs(q[16:18] - qpos0[16:18]).max())
            max_cube_dz = max(max_cube_dz, abs(q[18] - REST_Z))
        warnings = [w.number for w in physics.data.ptr.warning]
        return first, max_arm_move, max_cube_xy, max_cube_dz, warnings, ts.reward
    finally:
        env.task.close()


@pytest.mark.parametrize("seed", range(20))
def test_seeded_reset_is_quiet(seed):
    first, arm_move, cube_xy, cube_dz, warnings, reward = seeded_rollout(seed)
    np.testing.assert_array_equal(first["qpos"], START_ARM_POSE)
    np.testing.assert_array_equal(first["qvel"], 0.0)
    assert first["env_state"][2] == pytest.approx(REST_Z)
    assert warnings == [0] * len(warnings)
    assert arm_move < 1e-3
    assert cube_xy < 2e-3 and cube_dz < 2e-3
    assert reward == 0


def test_same_seed_same_cube_different_seeds_differ():
    def first_cube(seed):
        env = make_sim_env(TransferCubeTask, cam_list=[], random=seed)
        pose = env.reset().observation["env_state"].copy()
        env.task.close()
        return pose

    np.testing.assert_array_equal(first_cube(3), first_cube(3))
    assert not np.allclose(first_cube(3)[:2], first_cube(4)[:2])


def test_both_envs_place_the_same_cube_for_the_same_seed():
    from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask

    poses = []
    for task_class in (TransferCubeEETask, TransferCubeTask):
        env = make_sim_env(task_class, cam_list=[], random=8)
        poses.append(env.reset().observation["env_state"].copy())
        env.task.close()
    np.testing.assert_array_equal(poses[0], poses[1])


def test_box_pose_handover():
    """Vendor-style hand-over: BOX_POSE[0] set before reset places the cube."""
    pose = np.array([0.05, -0.1, REST_Z, 1.0, 0.0, 0.0, 0.0])
    sim_env.BOX_POSE[0] = pose
    env = make_sim_env(TransferCubeTask, cam_list=[], random=0)
    np.testing.assert_allclose(env.reset().observation["env_state"], pose)
    env.task.close()


def test_box_pose_argument_wins():
    pose = [-0.1, 0.05, REST_Z, 1.0, 0.0, 0.0, 0.0]
    BOX_POSE[0] = np.array([0.1, 0.1, REST_Z, 1.0, 0.0, 0.0, 0.0])
    env = make_sim_env(TransferCubeTask, cam_list=[], box_pose=pose)
    np.testing.assert_allclose(env.reset().observation["env_state"], pose)
    env.task.close()


def test_tool_target_is_the_current_ee_pose():
    env = make_sim_env(TransferCubeTask, cam_list=[], random=0)
    ts = env.reset()
    np.testing.assert_allclose(
        ts.observation["mocap_pose_left"][:3], [-0.019982, 0.194804, 0.270914], atol=1e-5
    )
    action = np.array(START_ARM_POSE)
    action[8] = 0.4  # turn the right arm
    for _ in range(50):
        ts = env.step(action)
    tool = env.task.tool_target(env.physics, "right_arm")
    np.testing.assert_allclose(ts.observation["mocap_pose_right"], tool)
    assert abs(tool[0] - (-0.019982)) > 0.05  # it moved with the arm
    env.task.close()


# --- the documented (ordered-pair) reward on a scripted transfer's joint replay -----------
class DocumentedRewardTask(TransferCubeTask):
    """The cube transfer scored by the documentation's ordered-pair reward, verbatim."""

    get_reward = MyJointTask.get_reward


@pytest.mark.parametrize("seed", [0, 1])
def test_documented_reward_scores_4_on_joint_replay(seed):
    from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings

    recorder = EpisodeRecorder(RecordSettings())
    actions, poses = recorder.scripted_rollout(np.random.default_rng(seed))
    recorder.close()
    env = make_sim_env(DocumentedRewardTask, cam_list=[], box_pose=poses["box"])
    env.reset()
    rewards, table_seen = [], 0
    for t, action in enumerate(actions):
        rewards.append(env.step(action).reward)
        if t < 50:
            data, model = env.physics.data, env.physics.model
            pairs = [
                (
                    model.id2name(data.contact[i].geom1, "geom"),
                    model.id2name(data.contact[i].geom2, "geom"),
                )
                for i in range(data.ncon)
            ]
            table_seen += ("red_box", "table") in pairs
    env.task.close()
    assert table_seen == 50
    assert rewards[-1] == 4
    assert {1, 2, 4} <= set(rewards)


# --- a transfer recorded with the vendor's own model grasps the cube here too -------------
VENDOR_EPISODE = Path(__file__).parent / "fixtures/vendor_transfer_cube_600steps_noimages"


def test_vendor_recorded_transfer_transfers_the_cube():
    """The vendor package's successful episode (its fingers, its grasp), replayed as joint
    actions from its cube spawn pose: the real-gripper finger geometry holds the cube."""
    meta = json.loads(VENDOR_EPISODE.with_suffix(".json").read_text())
    with h5py.File(VENDOR_EPISODE.with_suffix(".hdf5"), "r") as f:
        actions = f["action"][()]
    assert actions.shape == (600, 16)
    pose = np.array([*meta["box_xyz_at_spawn"], *meta["box_quat"]])
    env = make_sim_env(TransferCubeTask, cam_list=[], box_pose=pose)
    env.reset()
    rewards = [env.step(a).reward for a in actions]
    lifted = env.physics.data.qpos[18]
    env.task.close()
    assert rewards[-1] == 4, f"final reward {rewards[-1]}, max {max(rewards)}"
    assert lifted > 0.1  # held in the air by the left gripper
