"""Transfer-cube reward (0-4) from real contacts, and the cube's spawn distribution."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config
from trossen_arm_mujoco.robot.kinematics import Kinematics
from trossen_arm_mujoco.sim_env import TransferCubeTask
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.tasks.transfer_cube import (
    BOX_REST_Z,
    BOX_X_RANGE,
    BOX_Y_RANGE,
    MAX_REWARD,
    TransferCubeReward,
    sample_cube_pose,
)
from trossen_arm_mujoco.utils import make_sim_env

ASSETS = Path(ASSETS_DIR)
KIT_JOINT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"
# A resting cube sinks about 0.1 mm into the table under its soft contact (measured after
# settling); crafted states do the same, so the cube-table contact exists as in a rollout.
ON_TABLE = BOX_REST_Z - 1e-4
LIFTED = 0.12
FINGERS_ON_CUBE = 0.0124  # fingertip gap 2q: just under the 25 mm cube


def down_quat() -> np.ndarray:
    """Tool frame pointing down (x -> -z), fingers opening along world x."""
    rot = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.flatten())
    return quat


class Scene:
    """Crafts kinematic states of the joint scene (qpos + mj_forward), no stepping."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        self.model, self.data = model, data
        self.view = stationary_ai_joint_config().build_view(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)

    def grasp(self, side: str, cube_xyz) -> None:
        """Put ``side``'s fingers around a cube centred at cube_xyz, tool pointing down."""
        group = self.view.get_move_group(f"{side}_arm")
        kin = Kinematics(
            self.model, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range
        )
        # the cube centre sits 11 mm inside the fingertips (ee_site)
        site = np.asarray(cube_xyz, float) + [0.0, 0.0, -0.011]
        q, residual = kin.solve(self.data.qpos.copy(), site, down_quat(), iterations=200)
        assert residual < 1e-6, f"IK failed for the {side} arm: {residual}"
        group.set_qpos(self.data, q)
        self.view.get_move_group(f"{side}_gripper").set_qpos(self.data, [FINGERS_ON_CUBE] * 2)

    def place_cube(self, xyz) -> None:
        self.data.qpos[16:23] = [*xyz, 1.0, 0.0, 0.0, 0.0]

    def forward(self) -> None:
        mujoco.mj_forward(self.model, self.data)


@pytest.fixture
def scene():
    model = mujoco.MjModel.from_xml_path(str(KIT_JOINT))
    return Scene(model, mujoco.MjData(model))


def reward_of(scene: Scene) -> int:
    scene.forward()
    return TransferCubeReward(scene.model)(scene.data)


def test_max_reward():
    assert MAX_REWARD == 4


def test_reward_0_cube_on_the_table(scene):
    scene.place_cube([0.0, 0.0, ON_TABLE])
    assert reward_of(scene) == 0
    right, left, table = TransferCubeReward(scene.model).touching(scene.data)
    assert (right, left, table) == (False, False, True)


def test_reward_0_cube_in_the_air_untouched(scene):
    scene.place_cube([0.0, 0.0, 0.3])
    assert reward_of(scene) == 0


def test_reward_1_right_grasp_on_the_table(scene):
    cube = [0.0, -0.05, ON_TABLE]
    scene.place_cube(cube)
    scene.grasp("right", cube)
    assert reward_of(scene) == 1
    assert TransferCubeReward(scene.model).touching(scene.data) == (True, False, True)


def test_reward_2_right_grasp_lifted(scene):
    cube = [0.0, -0.05, LIFTED]
    scene.place_cube(cube)
    scene.grasp("right", cube)
    assert reward_of(scene) == 2


def test_reward_3_left_grasp_on_the_table(scene):
    cube = [0.0, 0.05, ON_TABLE]
    scene.place_cube(cube)
    scene.grasp("left", cube)
    assert reward_of(scene) == 3


def test_reward_4_left_grasp_lifted(scene):
    cube = [0.0, 0.05, LIFTED]
    scene.place_cube(cube)
    scene.grasp("left", cube)
    assert reward_of(scene) == 4


def test_open_fingers_around_the_cube_do_not_count(scene):
    cube = [0.0, -0.05, LIFTED]
    scene.place_cube(cube)
    scene.grasp("right", cube)
    scene.view.get_move_group("right_gripper").set_qpos(scene.data, [0.03, 0.03])
    assert reward_of(scene) == 0


def test_reward_through_both_envs(scene):
    """Both front doors score the same crafted state with the one reward implementation."""
    cube = [0.0, 0.05, LIFTED]
    for task_class in (TransferCubeTask, TransferCubeEETask):
        env = make_sim_env(task_class, cam_list=[], random=0)
        env.reset()
        physics = env.physics
        with physics.reset_context():
            physics.data.qpos[:] = 0.0
            physics.data.qpos[16:23] = [*cube, 1, 0, 0, 0]
            scene.data.qpos[16:23] = [*cube, 1, 0, 0, 0]
            scene.grasp("left", cube)
            physics.data.qpos[:16] = scene.data.qpos[:16]
        assert env.task.get_reward(physics) == 4, task_class.__name__
        env.task.close()


def test_pick_up_with_the_right_arm_reaches_reward_2():
    """Dynamic check: descend, close the right gripper on the cube (1), lift it (2)."""
    cube = np.array([0.0, -0.1, ON_TABLE])
    env = make_sim_env(TransferCubeTask, cam_list=[], box_pose=[*cube, 1, 0, 0, 0])
    env.reset()
    physics = env.physics
    group = env.task.robot(physics).view.get_move_group("right_arm")
    kin = Kinematics(
        physics.model.ptr, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range
    )
    qpos = physics.data.qpos.copy()
    q_above, _ = kin.solve(qpos, cube + [0, 0, 0.07], down_quat(), iterations=200)
    q_grasp, _ = kin.solve(qpos, cube + [0, 0, -0.011], down_quat(), iterations=200)
    action = np.array(START_ARM_POSE, dtype=float)
    rewards: list[int] = []

    def move(q, gripper, steps):
        start = action[8:14].copy()
        for k in range(steps):
            s = min(1.0, (k + 1) / (0.7 * steps))
            action[8:14] = start + s * (q - start)
            action[14:16] = gripper
            rewards.append(env.step(action).reward)

    move(q_above, 0.044, 60)
    move(q_grasp, 0.044, 50)
    assert max(rewards) == 0  # open fingers around the cube: no contact
    move(q_grasp, 0.0, 30)
    assert rewards[-1] == 1  # closed on the cube, which still rests on the table
    move(q_above, 0.0, 60)
    assert rewards[-1] == 2
    assert physics.data.qpos[18] > ON_TABLE + 0.05  # lifted
    assert all(w.number == 0 for w in physics.data.ptr.warning)
    env.task.close()


def test_sample_cube_pose_ranges_and_rest_height():
    rng = np.random.default_rng(7)
    poses = np.array([sample_cube_pose(rng) for _ in range(500)])
    assert poses.shape == (500, 7)
    assert poses[:, 0].min() >= BOX_X_RANGE[0] and poses[:, 0].max() <= BOX_X_RANGE[1]
    assert poses[:, 1].min() >= BOX_Y_RANGE[0] and poses[:, 1].max() <= BOX_Y_RANGE[1]
    # spread over the region, not stuck in a corner
    assert np.ptp(poses[:, 0]) > 0.8 * np.diff(BOX_X_RANGE)[0]
    assert np.ptp(poses[:, 1]) > 0.8 * np.diff(BOX_Y_RANGE)[0]
    np.testing.assert_allclose(poses[:, 2], 0.0325)
    np.testing.assert_allclose(poses[:, 3:], np.tile([1, 0, 0, 0], (500, 1)))


def test_sample_cube_pose_is_reproducible():
    a = sample_cube_pose(np.random.default_rng(3))
    b = sample_cube_pose(np.random.default_rng(3))
    c = sample_cube_pose(np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_reward_needs_the_named_geoms():
    model = mujoco.MjModel.from_xml_path(str(ASSETS / "wxai/wxai_follower.xml"))
    with pytest.raises(UserError, match="unknown geom 'red_box'"):
        TransferCubeReward(model)


# --- the task and sampler (one implementation for every front door) ----------------------
@pytest.fixture(scope="module")
def sampler():
    from trossen_arm_mujoco.tasks import registry

    s = registry.make_sampler("sim_transfer_cube")
    yield s
    s.close()


def test_cube_spawn_is_sample_cube_pose(sampler):
    task = sampler.sample_task(11)
    expected = sample_cube_pose(np.random.default_rng(11))
    np.testing.assert_allclose(task.get_observation()["env_state"], expected)
    np.testing.assert_allclose(task.get_observation()["qpos"], START_ARM_POSE)
    assert task.object_poses().keys() == {"box"}


def test_given_object_poses_win(sampler):
    pose = np.array([0.05, -0.1, BOX_REST_Z, 1.0, 0.0, 0.0, 0.0])
    task = sampler.sample_task(11, object_poses={"box": pose})
    np.testing.assert_allclose(task.env_state(), pose)
    with pytest.raises(UserError, match="box"):
        sampler.sample_task(11, object_poses={"peg": pose})


def test_reward_is_transfer_cube_reward(sampler):
    task = sampler.sample_task(0)
    reference = TransferCubeReward(sampler.scene.model)
    for _ in range(5):
        task.step({})
        assert task.get_reward() == reference(sampler.scene.data) == 0
    assert task.judge_success() is False
    assert isinstance(task.reward_fn, TransferCubeReward)


def test_every_finger_geom_counts_for_the_reward(sampler):
    reward = TransferCubeReward(sampler.scene.model)
    names = {
        mujoco.mj_id2name(sampler.scene.model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in reward.left
    }
    assert names == {
        f"left/gripper_follower_{f}{part}"
        for f in ("left", "right")
        for part in ("", "_pad_upper", "_pad_lower")
    }


def test_commands_reach_both_arms(sampler):
    task = sampler.sample_task(0)
    view = task.robot.view
    target = view.get_move_group("right_arm").get_qpos(task.data) + 0.2
    for _ in range(30):
        task.step({"right_arm": target, "right_gripper": np.array([0.02])})
    np.testing.assert_allclose(
        view.get_move_group("right_arm").get_qpos(task.data), target, atol=0.03
    )
    assert view.get_move_group("right_gripper").get_qpos(task.data)[1] == pytest.approx(
        0.02, abs=0.003
    )


def test_ee_flavour_drives_the_mocap_arms():
    from trossen_arm_mujoco.tasks import registry

    ee = registry.make_sampler(
        "transfer_cube", SamplerSettings(flavour="ee")
    )  # the old name is an alias
    try:
        task = ee.sample_task(3)
        obs = task.policy_observation()
        target = obs["mocap_pose_right"].copy()
        target[2] += 0.05
        for _ in range(25):
            task.step({"right_arm": target})
        np.testing.assert_allclose(task.tool_pose("right"), target, atol=1e-9)
        site = task.robot.view.get_move_group("right_arm").get_frame_pose(task.data)
        np.testing.assert_allclose(site[:3], target[:3], atol=2e-3)
    finally:
        ee.close()
