"""The shared dm_control task base of both kit envs: observations, action spec, validation."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.constants import DT, GRIPPER_OPEN, START_ARM_POSE, STATIONARY_CAMERAS
from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT
from trossen_arm_mujoco.sim_env import TransferCubeTask
from trossen_arm_mujoco.utils import make_sim_env

TASKS = [TransferCubeEETask, TransferCubeTask]
SMALL = (24, 32)


def hold_action(task_class, obs) -> np.ndarray:
    if task_class is TransferCubeEETask:
        return np.concatenate(
            [obs["mocap_pose_left"], [GRIPPER_OPEN], obs["mocap_pose_right"], [GRIPPER_OPEN]]
        )
    return np.array(START_ARM_POSE, dtype=float)


@pytest.fixture(params=TASKS, ids=lambda c: c.__name__)
def task_class(request):
    return request.param


@pytest.fixture
def env(task_class):
    env = make_sim_env(task_class, cam_list=[], random=0)
    yield env
    env.task.close()


def test_observation_keys_and_shapes(env, task_class):
    ts = env.reset()
    obs = ts.observation
    assert list(obs) == [
        "qpos",
        "qvel",
        "env_state",
        "images",
        "mocap_pose_left",
        "mocap_pose_right",
        "gripper_ctrl",
    ]
    shapes = {k: np.shape(v) for k, v in obs.items() if k != "images"}
    assert shapes == {
        "qpos": (16,),
        "qvel": (16,),
        "env_state": (7,),
        "mocap_pose_left": (7,),
        "mocap_pose_right": (7,),
        "gripper_ctrl": (2,),
    }
    assert obs["images"] == {}
    np.testing.assert_array_equal(obs["qpos"], START_ARM_POSE)
    np.testing.assert_array_equal(obs["qvel"], 0.0)
    np.testing.assert_allclose(obs["gripper_ctrl"], [GRIPPER_OPEN, GRIPPER_OPEN])
    np.testing.assert_allclose(np.linalg.norm(obs["env_state"][3:]), 1.0)
    for side in ("left", "right"):
        pose = obs[f"mocap_pose_{side}"]
        np.testing.assert_allclose(np.linalg.norm(pose[3:]), 1.0)
        # the tool-frame target at reset is the ee_site pose of START_ARM_POSE
        y = 0.194804 if side == "left" else -0.194804
        np.testing.assert_allclose(pose[:3], [-0.019982, y, 0.270914], atol=1e-5)
    ts = env.step(hold_action(task_class, obs))
    assert ts.reward == 0
    assert all(np.all(np.isfinite(v)) for k, v in ts.observation.items() if k != "images")


def test_observations_are_copies(env, task_class):
    ts = env.reset()
    qpos = ts.observation["qpos"]
    env_state = ts.observation["env_state"]
    qpos[:] = 7.0
    env_state[:] = 7.0
    assert env.physics.data.qpos[0] != 7.0 and env.physics.data.qpos[16] != 7.0


def test_images_only_requested_cameras(task_class):
    env = make_sim_env(task_class, cam_list=["cam_high", "cam_left_wrist"], image_size=SMALL)
    try:
        ts = env.reset()
        images = ts.observation["images"]
        assert list(images) == ["cam_high", "cam_left_wrist"]
        for img in images.values():
            assert img.shape == (*SMALL, 3) and img.dtype == np.uint8
            assert img.std() > 5
        ts = env.step(hold_action(task_class, ts.observation))
        assert list(ts.observation["images"]) == ["cam_high", "cam_left_wrist"]
    finally:
        env.task.close()


def test_default_cameras_are_the_four_recording_cameras(task_class):
    env = make_sim_env(task_class, image_size=SMALL)
    try:
        assert env.task.cam_list == list(STATIONARY_CAMERAS)
        ts = env.reset()
        assert list(ts.observation["images"]) == list(STATIONARY_CAMERAS)
    finally:
        env.task.close()


def test_unknown_camera_is_a_user_error(task_class):
    # names are looked up at construction, not at the first reset
    with pytest.raises(UserError, match="unknown camera 'cam_top'.*cam_high"):
        make_sim_env(task_class, cam_list=["cam_top"], image_size=SMALL)


BOTH_SIZES = r"action must have 14 values \(the real kit's layout\) or 16 \(the qpos layout\)"


@pytest.mark.parametrize(
    ("action", "ee_match", "joint_match"),
    [
        (np.zeros(15), "16 values, got 15", f"{BOTH_SIZES}, got 15"),
        (np.zeros(17), "16 values, got 17", f"{BOTH_SIZES}, got 17"),
        (np.zeros(14), "16 values, got 14", None),  # the joint env takes the kit's 14
        (np.full(16, np.nan), "NaN or inf", "NaN or inf"),
        (np.full(14, np.inf), "16 values, got 14", "NaN or inf"),
    ],
)
def test_action_validation(env, task_class, action, ee_match, joint_match):
    match = ee_match if task_class is TransferCubeEETask else joint_match
    env.reset()
    qpos = env.physics.data.qpos.copy()
    if match is None:  # valid: the step is taken
        env.step(action)
        assert not np.array_equal(env.physics.data.qpos, qpos)
        return
    with pytest.raises(UserError, match=match) as err:
        env.step(action)
    assert "\n" not in str(err.value)
    np.testing.assert_array_equal(env.physics.data.qpos, qpos)  # no step was taken


def test_single_nan_in_an_otherwise_valid_action(env, task_class):
    ts = env.reset()
    action = hold_action(task_class, ts.observation)
    action[3] = np.inf
    with pytest.raises(UserError, match="NaN or inf"):
        env.step(action)


def test_action_spec(env, task_class):
    env.reset()
    spec = env.action_spec()
    assert spec.shape == (16,)
    assert np.all(spec.minimum < spec.maximum)
    hold = hold_action(task_class, env.reset().observation)
    assert np.all(hold >= spec.minimum) and np.all(hold <= spec.maximum)
    if task_class is TransferCubeTask:
        np.testing.assert_allclose(spec.minimum[[6, 7, 14, 15]], 0.0)
        np.testing.assert_allclose(spec.maximum[[6, 7, 14, 15]], GRIPPER_OPEN)
        np.testing.assert_allclose(spec.maximum[1], 3.14159)  # joint_1 limit


def test_control_timestep(env):
    assert env.control_timestep() == pytest.approx(DT)
    env.reset()
    env.step(hold_action(type(env.task), env.reset().observation))
    assert env.physics.data.time == pytest.approx(DT)


def test_joint_action_mapping():
    """Joint env: indices 6/14 (coupled fingers) are not commanded; 7/15 drive the grippers."""
    env = make_sim_env(TransferCubeTask, cam_list=[], random=0)
    env.reset()
    # targets within one step's reach of the speed limits (3.375 rad/s, 0.0875 m/s; 0.02 s)
    action = np.array(START_ARM_POSE, dtype=float)
    action[0] = 0.05
    action[6] = 0.0  # ignored
    action[15] = GRIPPER_OPEN - 0.001
    env.step(action)
    ctrl = env.physics.data.ctrl
    np.testing.assert_allclose(ctrl[0], 0.05)
    np.testing.assert_allclose(ctrl[6], GRIPPER_OPEN)  # left gripper from action[7]
    np.testing.assert_allclose(ctrl[13], GRIPPER_OPEN - 0.001)  # right gripper from action[15]
    env.task.close()


def test_joint_env_takes_the_real_kits_14_values():
    """A 14-value action (KIT14_LAYOUT) drives the joint env exactly as its 16 values."""
    rng = np.random.default_rng(0)
    start = np.array(START_ARM_POSE, dtype=float)
    actions = []
    for t in range(1, 9):  # small moves within the speed limits, grippers closing
        a = start.copy()
        a[:6] += 0.01 * t * rng.uniform(-1, 1, 6)
        a[8:14] += 0.01 * t * rng.uniform(-1, 1, 6)
        a[[7, 15]] = GRIPPER_OPEN - 0.001 * t
        a[[6, 14]] = rng.uniform(0, GRIPPER_OPEN, 2)  # coupled fingers: not commanded
        actions.append(a)
    runs = []
    for layout in ("vendor16", "kit14"):
        env = make_sim_env(TransferCubeTask, cam_list=[], random=3)
        env.reset()
        qpos = []
        for a in actions:
            ts = env.step(a if layout == "vendor16" else KIT14_LAYOUT.from_vendor(a))
            qpos.append(ts.observation["qpos"])
        runs.append((np.array(qpos), env.physics.data.qpos.copy(), env.physics.data.ctrl.copy()))
        env.task.close()
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(runs[0][0][0], runs[0][0][-1])  # the arms did move


def test_ee_action_moves_mocap_targets():
    env = make_sim_env(TransferCubeEETask, cam_list=[], random=0)
    ts = env.reset()
    action = hold_action(TransferCubeEETask, ts.observation)
    action[0:3] += [0.02, 0.0, -0.01]
    action[7] = 0.02
    ts = env.step(action)
    np.testing.assert_allclose(env.physics.data.mocap_pos[0], action[0:3])
    np.testing.assert_allclose(ts.observation["mocap_pose_left"][:3], action[0:3])
    # the finger target moves toward 0.02 at the carriage speed limit (0.0875 m/s)
    closing = GRIPPER_OPEN - JOINT_VELOCITY_LIMITS["left_carriage_joint"] * DT
    np.testing.assert_allclose(ts.observation["gripper_ctrl"], [closing, GRIPPER_OPEN])
    for _ in range(50):
        ts = env.step(action)
    tool = (
        env.task.robot(env.physics)
        .view.get_move_group("left_arm")
        .get_frame_pose(env.physics.data.ptr)
    )
    np.testing.assert_allclose(tool[:3], action[0:3], atol=2e-3)
    np.testing.assert_allclose(ts.observation["qpos"][6:8], [0.02, 0.02], atol=1e-3)
    env.task.close()
