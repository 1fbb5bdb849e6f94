"""KitPolicyEnv: spaces, seeds, the 14- and 16-value layouts, action checks, rates, render."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.env import (
    KitPolicyEnv,
    episode_generator,
    feature_spec,
    parse_cameras,
    parse_image_size,
    rate_timing,
)
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE

SIZE = (24, 32)
START14 = KIT14_LAYOUT.from_vendor(np.asarray(START_ARM_POSE))


@pytest.fixture
def make_env():
    """``make_env(task, **kwargs)``: a KitPolicyEnv closed at teardown (tiny images)."""
    envs: list[KitPolicyEnv] = []

    def make(task: str = "sim_transfer_cube", **kwargs) -> KitPolicyEnv:
        kwargs.setdefault("image_size", SIZE)
        env = KitPolicyEnv(task, **kwargs)
        envs.append(env)
        return env

    yield make
    for env in envs:
        env.close()


def _qpos(env: KitPolicyEnv) -> np.ndarray:
    return np.asarray(env.task.get_observation()["qpos"], dtype=float).copy()


# -- spaces ---------------------------------------------------------------------------------
@pytest.mark.parametrize("layout,size", [("kit14", 14), ("vendor16", 16)])
@pytest.mark.parametrize("cams", [(), ("cam_high", "cam_low")])
def test_spaces_contain_the_observations(make_env, layout, size, cams):
    env = make_env(cam_names=cams, layout=layout, episode_length=3)
    space = env.observation_space
    assert set(space.spaces) == {"agent_pos", "velocity", "environment_state"} | (
        {"pixels"} if cams else set()
    )
    assert space["agent_pos"].shape == space["velocity"].shape == (size,)
    assert env.action_space.shape == (size,) and env.action_space.dtype == np.float32
    env.action_space.seed(0)
    obs, info = env.reset(seed=0)
    assert space.contains(obs), {k: v for k, v in obs.items() if k != "pixels"}
    assert info == {"is_success": False, "stage": 0.0}
    if cams:
        assert set(obs["pixels"]) == set(cams)
        for image in obs["pixels"].values():
            assert image.shape == (*SIZE, 3) and image.dtype == np.uint8
    else:
        assert "pixels" not in obs
    for _ in range(2):
        obs, *_ = env.step(env.action_space.sample())
        assert space.contains(obs)
    # the observation is the task's qpos in the layout's order (inside the joint ranges)
    qpos16 = _qpos(env)
    expected = KIT14_LAYOUT.from_vendor(qpos16) if size == 14 else qpos16
    expected = np.clip(expected.astype(np.float32), space["agent_pos"].low, space["agent_pos"].high)
    np.testing.assert_array_equal(obs["agent_pos"], expected)


@pytest.mark.parametrize("layout", ["kit14", "vendor16"])
def test_observations_stay_inside_the_space_when_a_finger_overshoots(make_env, layout):
    """A finger pressed ~0.1 mm past its range (MuJoCo's joint limits are soft): the
    observation is clipped into its space, like the gym env's state."""
    env = make_env(layout=layout)
    env.reset(seed=0)
    space = env.observation_space
    scene = env.scene
    for name in ("left/left_carriage_joint", "right/right_carriage_joint"):
        joint = scene.model.joint(name)
        scene.data.qpos[joint.qposadr[0]] = joint.range[1] + 1e-4
    raw = env._to_layout(_qpos(env))
    assert (raw > space["agent_pos"].high).any()  # the case this test is about
    obs = env._observe()
    assert space.contains(obs)
    np.testing.assert_array_equal(
        obs["agent_pos"], np.minimum(raw.astype(np.float32), space["agent_pos"].high)
    )


def test_feature_spec_names_what_the_env_observes():
    spec = feature_spec("sim_insertion", ("cam_high",), (48, 64), "kit14")
    assert set(spec) == {
        "action",
        "agent_pos",
        "velocity",
        "environment_state",
        "observation.images.cam_high",
    }
    assert spec["action"] == ("action", "ACTION", (14,))
    assert spec["agent_pos"] == ("observation.state", "STATE", (14,))
    assert spec["velocity"] == ("observation.velocity", "STATE", (14,))
    assert spec["environment_state"] == ("observation.environment_state", "ENV", (14,))
    image = ("observation.images.cam_high", "VISUAL", (48, 64, 3))
    assert spec["observation.images.cam_high"] == image
    assert feature_spec("sim_transfer_cube", (), (1, 1), "vendor16")["environment_state"][2] == (7,)


# -- seeds ----------------------------------------------------------------------------------
def test_reset_seed_is_deterministic_and_seeds_differ(make_env):
    env = make_env()
    first = env.reset(seed=7)[0]["environment_state"].copy()
    other = env.reset(seed=8)[0]["environment_state"].copy()
    again = env.reset(seed=7)[0]["environment_state"].copy()
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)
    # another env, same seed: the same episode
    fresh = make_env().reset(seed=7)[0]["environment_state"]
    np.testing.assert_array_equal(first, fresh)


def test_evaluation_streams_are_never_recording_streams():
    draws = 4
    evaluation = {s: episode_generator(s).integers(2**63, size=draws) for s in range(20)}
    for s, values in evaluation.items():
        np.testing.assert_array_equal(values, episode_generator(s).integers(2**63, size=draws))
    recording = [
        np.random.default_rng(episode_seed(s, a)).integers(2**63, size=draws)
        for s in range(20)
        for a in range(50)
    ]
    recording += [np.random.default_rng(s).integers(2**63, size=draws) for s in range(20)]
    seen = {int(v[0]) for v in recording}
    for s, values in evaluation.items():
        assert int(values[0]) not in seen, s
    assert len({int(v[0]) for v in evaluation.values()}) == len(evaluation)


@pytest.mark.parametrize("seed", [-1, -(2**40), 1.5, True, "3"])
def test_episode_generator_rejects_bad_seeds(seed):
    with pytest.raises(UserError, match="non-negative int"):
        episode_generator(seed)


# -- actions --------------------------------------------------------------------------------
def test_14_and_equivalent_16_value_actions_give_identical_qpos(make_env):
    kit, vendor = make_env(layout="kit14"), make_env(layout="vendor16")
    kit.reset(seed=3)
    vendor.reset(seed=3)
    np.testing.assert_array_equal(_qpos(kit), _qpos(vendor))
    rng = np.random.default_rng(0)
    for t in range(8):
        a14 = START14 + rng.uniform(-0.2, 0.2, 14)
        a14[[6, 13]] = 0.01 + 0.004 * t  # the grippers close step by step
        a16 = KIT14_LAYOUT.to_vendor(a14)
        assert a16[6] == a16[7] == a14[6] and a16[14] == a16[15] == a14[13]
        obs14, r14, *_ = kit.step(a14)
        obs16, r16, *_ = vendor.step(a16)
        np.testing.assert_array_equal(_qpos(kit), _qpos(vendor))
        np.testing.assert_array_equal(
            obs14["agent_pos"], KIT14_LAYOUT.from_vendor(obs16["agent_pos"])
        )
        assert r14 == r16


def test_out_of_limit_actions_are_clipped_and_the_callers_array_kept(make_env):
    """With the controller's checks off, goals outside the joint ranges are clipped to them
    (with them on, such a goal is a fault: tests/eval/test_controller_checks.py)."""
    over, at_limit = make_env(controller_checks=False), make_env(controller_checks=False)
    over.reset(seed=1)
    at_limit.reset(seed=1)
    high = over.action_high.copy()
    action = high + 10.0
    action[3] = over.action_low[3] - 10.0
    target = high.copy()
    target[3] = over.action_low[3]
    for _ in range(3):
        over.step(action)
        at_limit.step(target)
    np.testing.assert_array_equal(_qpos(over), _qpos(at_limit))
    assert action[0] == high[0] + 10.0  # clipping works on a copy, not on the policy's array


@pytest.mark.parametrize(
    "action,match",
    [
        (np.r_[START14[:-1], np.nan], "NaN or inf"),
        (np.r_[START14[:-1], np.inf], "NaN or inf"),
        (START14[:13], "must have 14 values"),
        (np.r_[START14, 0.0, 0.0], "must have 14 values"),
    ],
)
def test_bad_actions_raise_user_errors(make_env, action, match):
    env = make_env(controller_checks=False)  # checks on: NaN is the controller's fault
    with pytest.raises(UserError, match="reset"):
        env.step(START14)
    env.reset(seed=0)
    with pytest.raises(UserError, match=match):
        env.step(action)


# -- rates and length -----------------------------------------------------------------------
def test_30_fps_rates_and_default_length(make_env):
    assert rate_timing(30) == pytest.approx(
        {"policy_dt": 1 / 30, "ctrl_dt": 1 / 30, "sim_dt": 1 / 510}
    )
    assert rate_timing(50) == pytest.approx({"policy_dt": 0.02, "ctrl_dt": 0.02, "sim_dt": 0.002})
    env = make_env(fps=30)
    env.reset(seed=0)
    assert env.task.policy_dt == pytest.approx(1 / 30)
    assert env.scene.model.opt.timestep == pytest.approx(1 / 510)
    assert env.scene.n_substeps == 1  # the controllers tick every physics step
    assert env.task.n_ctrl_steps == 17
    assert env.episode_length == 360  # the transfer's 12 s
    assert env._max_episode_steps == 360  # the same, under the name LeRobot's eval reads
    assert env.metadata["render_fps"] == 30
    native = make_env()
    assert native.fps == 50 and native.episode_length == 600
    assert make_env("sim_insertion").episode_length == 400


@pytest.mark.parametrize("fps", [0, 0.5, 501, float("nan"), "30"])
def test_bad_rates_are_user_errors(fps):
    with pytest.raises(UserError, match="fps must be a number"):
        rate_timing(fps)


def test_truncated_at_episode_length_never_terminated(make_env):
    env = make_env(episode_length=3)
    env.reset(seed=0)
    flags = []
    for _ in range(3):
        _, reward, terminated, truncated, info = env.step(START14)
        flags.append((terminated, truncated))
        assert info["stage"] == reward and info["is_success"] is False
    assert flags == [(False, False), (False, False), (False, True)]
    env.reset(seed=1)  # a new episode counts from zero
    assert env.step(START14)[3] is False


@pytest.mark.parametrize("length", [0, 2.5, True, 100_001])
def test_bad_episode_length_is_a_user_error(length):
    with pytest.raises(UserError, match="episode_length"):
        KitPolicyEnv(episode_length=length)


# -- render, names --------------------------------------------------------------------------
def test_render_shapes(make_env):
    cams = make_env(cam_names=("cam_high", "cam_low"))
    assert cams.render() is None  # nothing to show before the first reset
    obs, _ = cams.reset(seed=0)
    frame = cams.render()
    assert frame.shape == (SIZE[0], 2 * SIZE[1], 3) and frame.dtype == np.uint8
    np.testing.assert_array_equal(frame[:, : SIZE[1]], obs["pixels"]["cam_high"])
    bare = make_env()
    bare.reset(seed=0)
    frame = bare.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.any()
    quiet = make_env(render_mode=None)
    quiet.reset(seed=0)
    assert quiet.render() is None


def test_a_cropped_camera_shows_its_rectangle_of_the_frame(make_env):
    crop = "cam_high:216,240,150,200"  # the transfer cube's spawn region
    cropped = make_env(cam_names=("cam_high",), image_size=(30, 40), crops=(crop,))
    whole = make_env(cam_names=("cam_high",), image_size=(480, 640))
    assert cropped.cameras.crop_texts() == (crop,) and whole.cameras.crops == ()
    image = cropped.reset(seed=0)[0]["pixels"]["cam_high"].astype(float)
    full = whole.reset(seed=0)[0]["pixels"]["cam_high"].astype(float)
    scaled = full[216:366, 240:440].reshape(30, 5, 40, 5, 3).mean(axis=(1, 3))
    assert np.abs(image - scaled).mean() < 8.0  # the same rectangle, 5x smaller
    assert np.abs(image - full[::16, ::16]).mean() > 20.0  # not the whole frame
    with pytest.raises(UserError, match="camera cam_nope is not observed"):
        make_env(cam_names=("cam_high",), crops=("cam_nope:0,0,10,10",))
    with pytest.raises(UserError, match="valid cameras"):  # observed but not in the scene
        make_env(cam_names=("cam_nope",), crops=("cam_nope:0,0,10,10",))


def test_the_cameras_come_as_one_settings_object_or_as_the_three_values(make_env):
    from trossen_arm_mujoco.sim.camera_settings import CameraSettings

    cams = CameraSettings.from_cli("cam_high", "24x32", "cam_high:216,240,150,200")
    env = make_env(cameras=cams, image_size=None)
    assert env.cameras is cams and env.cam_names == ("cam_high",) and env.image_size == (24, 32)
    assert env.observation_space["pixels"]["cam_high"].shape == (24, 32, 3)
    loose = make_env(cam_names="cam_high", image_size="24x32", crops="cam_high:216,240,150,200")
    assert loose.cameras == cams
    with pytest.raises(UserError, match="not both"):
        KitPolicyEnv(cameras=cams, image_size=(24, 32))
    with pytest.raises(UserError, match="must be a CameraSettings"):
        KitPolicyEnv(cameras=("cam_high",))


def test_the_env_draws_the_frames_as_the_camera_settings_say(make_env):
    from trossen_arm_mujoco.sim.camera_settings import CameraSettings

    cams = CameraSettings(("cam_high",), (24, 32), shadows=False, antialias=False)
    model = make_env(cameras=cams, image_size=None).scene.model
    assert model.vis.quality.offsamples == 0 and not model.light_castshadow.any()
    default = make_env(cam_names="cam_high").scene.model
    assert default.vis.quality.offsamples > 0 and default.light_castshadow.any()


def test_task_name_and_description(make_env):
    for task in ("sim_transfer_cube", "sim_insertion"):
        env = make_env(task)
        assert env.task_name == task
        assert isinstance(env.task_description, str) and env.task_description.strip()
    assert make_env("transfer_cube").task_name == "sim_transfer_cube"  # an alias


def test_single_arm_task_is_refused_with_its_layout():
    """A single arm's task runs in eval.arm_env.ArmPolicyEnv (layout widowxai), not here."""
    with pytest.raises(UserError) as err:
        KitPolicyEnv("reach")
    message = str(err.value)
    assert "\n" not in message
    assert message == "task 'reach' takes the layouts widowxai, not 'kit14' (--layout)"


def test_unknown_camera_and_layout_are_user_errors():
    with pytest.raises(UserError, match="cam_nope"):
        KitPolicyEnv(cam_names=("cam_nope",), image_size=SIZE)
    with pytest.raises(UserError, match="kit14, vendor16"):
        KitPolicyEnv(layout="kit15")


# -- parsers --------------------------------------------------------------------------------
def test_parse_image_size():
    assert parse_image_size("96x128") == (96, 128)
    assert parse_image_size("96X128") == (96, 128)
    assert parse_image_size((24, 32)) == (24, 32)
    for bad in ("96", "96x", "x128", "0x128", "96x-1", "96x128x3", "axb", ""):
        with pytest.raises(UserError, match="HxW"):
            parse_image_size(bad)


def test_parse_cameras():
    assert parse_cameras(None) == ()
    assert parse_cameras("") == ()
    assert parse_cameras("none") == () and parse_cameras("None") == ()
    assert parse_cameras("cam_high, cam_low,") == ("cam_high", "cam_low")
    assert parse_cameras(["cam_low"]) == ("cam_low",)


# -- reset options --------------------------------------------------------------------------
def test_reset_object_poses_place_the_named_objects_and_others_keep_the_seeds(make_env):
    env = make_env("sim_insertion")
    sampled = env.reset(seed=3)[0]["environment_state"].copy()  # peg (7), socket (7)
    peg = np.array([0.05, -0.02, 0.02, 0.0, 0.0, 0.0, 2.0])  # quaternion normalised
    placed = env.reset(seed=3, options={"object_poses": {"peg": peg}})[0]["environment_state"]
    np.testing.assert_allclose(placed[:7], [0.05, -0.02, 0.02, 0.0, 0.0, 0.0, 1.0], atol=1e-7)
    np.testing.assert_array_equal(placed[7:], sampled[7:])
    again = env.reset(seed=3, options={"object_poses": None})[0]["environment_state"]
    np.testing.assert_array_equal(again, sampled)


@pytest.mark.parametrize(
    "options,match",
    [
        ([1, 2], "reset options must be a dict"),
        ({"object_pose": {}}, "unknown reset option"),
        ({"object_poses": [0.0] * 7}, "object_poses must be a dict"),
        ({"object_poses": {"cube": [0.0] * 7}}, "object_poses 'cube'; valid .*: box"),
        ({"object_poses": {"box": [0.0] * 6}}, r"object_poses\['box'\] must be 7 finite"),
        ({"object_poses": {"box": [0, 0, 0, float("nan"), 1, 0, 0]}}, "7 finite"),
        ({"object_poses": {"box": [0.0] * 7}}, "non-zero quaternion"),
        ({"object_poses": {"box": "up"}}, "7 finite"),
    ],
)
def test_bad_reset_options_are_user_errors(make_env, options, match):
    env = make_env()
    with pytest.raises(UserError, match=match):
        env.reset(seed=0, options=options)


def test_lerobot_evals_rollout_marker_is_accepted(make_env):
    """lerobot-eval resets with ``options={"lerobot_new_rollout": True}`` (passed on by its
    FreezeAfterEpisodeEnd wrapper): the same episode as no options."""
    env = make_env()
    plain = env.reset(seed=4)[0]["environment_state"].copy()
    marked = env.reset(seed=4, options={"lerobot_new_rollout": True})[0]["environment_state"]
    np.testing.assert_array_equal(plain, marked)
