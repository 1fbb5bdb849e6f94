"""Peg insertion: reward stages (0-4) from crafted kinematic states, the spawn sampler and
the Task/TaskSampler pair."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from trossen_arm_mujoco.constants import ASSETS_DIR, START_ARM_POSE
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.policies.insertion import InsertionPolicy
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config
from trossen_arm_mujoco.robot.kinematics import Kinematics
from trossen_arm_mujoco.tasks.config import CONFIG_DIR
from trossen_arm_mujoco.tasks.insertion import (
    MAX_REWARD,
    PEG_HALF,
    PEG_REST_Z,
    PEG_X_RANGE,
    PEG_Y_RANGE,
    PIN_FACE_Y,
    SOCKET_INNER_HALF,
    SOCKET_MOUTH_Y,
    SOCKET_REST_Z,
    SOCKET_X_RANGE,
    SOCKET_Y_RANGE,
    InsertionReward,
    InsertionSampler,
    InsertionTask,
    sample_insertion_poses,
)
from trossen_arm_mujoco.tasks.registry import load as load_task
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

JOINT_XML = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_insertion_scene_joint.xml"
SINK = 1e-4  # resting objects sink about 0.1 mm into the table under their soft contact
LIFT = 0.12
#: Finger travel q gives a pad gap of 2q - 0.18 mm (facts A5); squeeze 0.3 mm per side.
PEG_FINGERS = (2 * PEG_HALF[0] - 0.0006 + 0.00018) / 2
SOCKET_FINGERS = (2 * 0.016 - 0.0006 + 0.00018) / 2
#: Tool frame relative to the object centres in the grasps (as the scripted policy's).
PEG_GRIP = np.array([0.0, -0.015, 0.001])
SOCKET_GRIP = np.array([0.0, 0.008, -0.005])


def load_task_config(name: str, **overrides):
    """A shipped task's config by its name, validated with its own keys."""
    return load_task(name).load_config(**overrides)


class Scene:
    """Crafts kinematic states of the joint scene (qpos + mj_forward), no stepping."""

    def __init__(self):
        self.model = mujoco.MjModel.from_xml_path(str(JOINT_XML))
        self.data = mujoco.MjData(self.model)
        self.view = stationary_ai_joint_config().build_view(self.model)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key("home").id)
        mujoco.mj_kinematics(self.model, self.data)
        self.home_quat = {
            side: self.view.get_move_group(f"{side}_arm").get_frame_pose(self.data)[3:]
            for side in ("left", "right")
        }

    def place(self, peg=None, socket=None) -> None:
        if peg is not None:
            self.data.qpos[16:23] = [*peg, 1.0, 0.0, 0.0, 0.0]
        if socket is not None:
            self.data.qpos[23:30] = [*socket, 1.0, 0.0, 0.0, 0.0]

    def grasp(self, side: str, tool_xyz, fingers: float) -> None:
        """Put ``side``'s tool frame at tool_xyz in the policy's grasp orientation."""
        group = self.view.get_move_group(f"{side}_arm")
        kin = Kinematics(
            self.model, group.frame_site_id, group.qpos_idx, group.dof_idx, group.joint_range
        )
        quat = InsertionPolicy.grasp_quat(self.home_quat[side])
        q, residual = kin.solve(self.data.qpos.copy(), np.asarray(tool_xyz), quat, iterations=300)
        assert residual < 1e-6, f"IK failed for the {side} arm: {residual}"
        group.set_qpos(self.data, q)
        self.view.get_move_group(f"{side}_gripper").set_qpos(self.data, [fingers, fingers])

    def grasp_peg(self, peg) -> None:
        self.grasp("right", np.asarray(peg) + PEG_GRIP, PEG_FINGERS)

    def grasp_socket(self, socket) -> None:
        self.grasp("left", np.asarray(socket) + SOCKET_GRIP, SOCKET_FINGERS)

    def reward(self) -> int:
        mujoco.mj_forward(self.model, self.data)
        return InsertionReward(self.model)(self.data)

    def contacts(self) -> dict[str, bool]:
        mujoco.mj_forward(self.model, self.data)
        return InsertionReward(self.model).contacts(self.data)


PEG_TABLE = np.array([0.03, -0.15, PEG_REST_Z - SINK])
SOCKET_TABLE = np.array([0.03, 0.15, SOCKET_REST_Z - SINK])
SOCKET_AIR = np.array([0.02, 0.06, 0.16])


def peg_in_socket(depth: float, drop: float = 0.0) -> np.ndarray:
    """Peg centre with its tip ``depth`` past the socket's mouth (SOCKET_AIR), lowered by
    ``drop`` from the hole's axis."""
    tip_y = SOCKET_AIR[1] + SOCKET_MOUTH_Y + depth
    return SOCKET_AIR + [0.0, tip_y - SOCKET_AIR[1] - PEG_HALF[1], -drop]


@pytest.fixture
def scene():
    return Scene()


def test_max_reward():
    assert MAX_REWARD == InsertionTask.max_reward == 4


def test_reward_0_on_the_table(scene):
    scene.place(peg=PEG_TABLE, socket=SOCKET_TABLE)
    assert scene.reward() == 0
    c = scene.contacts()
    assert c["peg_table"] and c["socket_table"] and not (c["right_peg"] or c["left_socket"])


def test_reward_0_with_one_gripper_only(scene):
    scene.place(peg=PEG_TABLE, socket=SOCKET_TABLE)
    scene.grasp_peg(PEG_TABLE)
    assert scene.contacts()["right_peg"]
    assert scene.reward() == 0


def test_reward_1_both_grasped_on_the_table(scene):
    scene.place(peg=PEG_TABLE, socket=SOCKET_TABLE)
    scene.grasp_peg(PEG_TABLE)
    scene.grasp_socket(SOCKET_TABLE)
    assert scene.reward() == 1


def test_reward_1_when_one_object_still_on_the_table(scene):
    peg = np.array([0.03, -0.12, LIFT])
    scene.place(peg=peg, socket=SOCKET_TABLE)
    scene.grasp_peg(peg)
    scene.grasp_socket(SOCKET_TABLE)
    assert scene.reward() == 1


def test_reward_2_both_lifted(scene):
    peg, socket = np.array([0.03, -0.12, LIFT]), np.array([0.03, 0.12, LIFT])
    scene.place(peg=peg, socket=socket)
    scene.grasp_peg(peg)
    scene.grasp_socket(socket)
    assert scene.reward() == 2


def test_reward_3_peg_touches_the_socket(scene):
    # tip 10 mm inside, resting on the lower wall's inner face
    peg = peg_in_socket(0.01, drop=SOCKET_INNER_HALF - PEG_HALF[2] + SINK)
    scene.place(peg=peg, socket=SOCKET_AIR)
    scene.grasp_peg(peg)
    scene.grasp_socket(SOCKET_AIR)
    c = scene.contacts()
    assert c["peg_socket"] and not c["peg_pin"]
    assert scene.reward() == 3


def test_reward_4_peg_touches_the_pin(scene):
    peg = peg_in_socket(PIN_FACE_Y - SOCKET_MOUTH_Y + SINK)
    scene.place(peg=peg, socket=SOCKET_AIR)
    scene.grasp_peg(peg)
    scene.grasp_socket(SOCKET_AIR)
    assert scene.contacts()["peg_pin"]
    assert scene.reward() == 4


def test_inserted_but_not_quite_at_the_pin_is_2(scene):
    peg = peg_in_socket(PIN_FACE_Y - SOCKET_MOUTH_Y - 0.002)  # centred, 2 mm short
    scene.place(peg=peg, socket=SOCKET_AIR)
    scene.grasp_peg(peg)
    scene.grasp_socket(SOCKET_AIR)
    assert scene.reward() == 2


def test_pin_contact_needs_both_grippers(scene):
    peg = peg_in_socket(PIN_FACE_Y - SOCKET_MOUTH_Y + SINK)
    scene.place(peg=peg, socket=SOCKET_AIR)
    scene.grasp_socket(SOCKET_AIR)
    assert scene.contacts()["peg_pin"]
    assert scene.reward() == 0


def test_open_fingers_do_not_count(scene):
    peg, socket = np.array([0.03, -0.12, LIFT]), np.array([0.03, 0.12, LIFT])
    scene.place(peg=peg, socket=socket)
    scene.grasp_peg(peg)
    scene.grasp_socket(socket)
    scene.view.get_move_group("right_gripper").set_qpos(scene.data, [0.03, 0.03])
    assert scene.reward() == 0


def test_reward_needs_the_named_geoms():
    model = mujoco.MjModel.from_xml_path(
        str(Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene_joint.xml")
    )
    with pytest.raises(UserError, match="unknown geom 'peg'"):
        InsertionReward(model)


# -- spawn sampler ------------------------------------------------------------------------
def test_sample_poses_ranges():
    rng = np.random.default_rng(7)
    pegs, sockets = map(np.array, zip(*(sample_insertion_poses(rng) for _ in range(500))))
    for poses, xr, yr, z in (
        (pegs, PEG_X_RANGE, PEG_Y_RANGE, PEG_REST_Z),
        (sockets, SOCKET_X_RANGE, SOCKET_Y_RANGE, SOCKET_REST_Z),
    ):
        assert poses.shape == (500, 7)
        assert xr[0] <= poses[:, 0].min() and poses[:, 0].max() <= xr[1]
        assert yr[0] <= poses[:, 1].min() and poses[:, 1].max() <= yr[1]
        assert np.ptp(poses[:, 0]) > 0.8 * np.diff(xr)[0]
        assert np.ptp(poses[:, 1]) > 0.8 * np.diff(yr)[0]
        np.testing.assert_allclose(poses[:, 2], z)
        np.testing.assert_allclose(poses[:, 3:], np.tile([1, 0, 0, 0], (500, 1)))
    assert pegs[:, 1].max() < 0 < sockets[:, 1].min()  # peg right, socket left


def test_sample_poses_reproducible():
    a = sample_insertion_poses(np.random.default_rng(3))
    b = sample_insertion_poses(np.random.default_rng(3))
    c = sample_insertion_poses(np.random.default_rng(4))
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[0], c[0]) and not np.array_equal(a[1], c[1])


# -- task and sampler ---------------------------------------------------------------------
def test_config_has_the_transfer_keys_and_both_scenes():
    config = load_task_config("insertion")
    transfer = yaml.safe_load((CONFIG_DIR / "transfer_cube.yaml").read_text())
    assert set(config) == set(transfer) | {"ee_scene"}
    assert config["scene"] == "stationary_ai/trossen_ai_insertion_scene_joint.xml"
    assert config["ee_scene"] == "stationary_ai/trossen_ai_insertion_scene.xml"
    assert config["max_episode_steps"] >= InsertionPolicy.minimum_episode_len


@pytest.fixture(scope="module")
def sampler():
    s = InsertionSampler(load_task_config("insertion"))
    yield s
    s.close()


def test_sampler_places_the_sampled_poses(sampler):
    task = sampler.sample_task(11)
    assert isinstance(task, InsertionTask)
    peg, socket = sample_insertion_poses(np.random.default_rng(11))
    obs = task.get_observation()
    np.testing.assert_allclose(obs["env_state"], np.concatenate([peg, socket]))
    np.testing.assert_allclose(obs["qpos"], START_ARM_POSE)
    assert obs["qpos"].shape == obs["qvel"].shape == (16,)
    assert obs["env_state"].shape == (14,)
    bounds = task.observation_bounds()
    for key in ("qpos", "qvel", "env_state"):
        low, high = bounds[key]
        assert low.shape == high.shape == obs[key].shape
        assert np.all(low <= obs[key]) and np.all(obs[key] <= high)


def test_sampler_seeds(sampler):
    a = sampler.sample_task(5).get_observation()["env_state"]
    b = sampler.sample_task(5).get_observation()["env_state"]
    c = sampler.sample_task(6).get_observation()["env_state"]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_task_scores_and_describes(sampler):
    task = sampler.sample_task(0)
    for _ in range(5):
        task.step({})
    assert task.get_reward() == 0 and task.judge_success() is False
    assert isinstance(task.reward_fn, InsertionReward)
    text = task.get_task_description()
    assert "peg" in text and "socket" in text


def test_mocap_flavour(sampler):
    ee = InsertionSampler(load_task_config("insertion"), SamplerSettings(flavour="ee"))
    try:
        task = ee.sample_task(11)
        obs = task.policy_observation()
        np.testing.assert_allclose(obs["env_state"], sampler.sample_task(11).env_state())
        assert obs["mocap_pose_left"].shape == obs["mocap_pose_right"].shape == (7,)
        assert ee.scene.model.nmocap == 2
    finally:
        ee.close()
