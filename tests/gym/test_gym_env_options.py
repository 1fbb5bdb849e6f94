"""Env options: observation types, rendering, config overrides, registration, seeding."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.registration import ENV_IDS, register_envs

REACH = "TrossenMujoco/WXAIReach-v0"
PUSH = "TrossenMujoco/WXAIPush-v0"
TRANSFER = "TrossenMujoco/StationaryAITransferCube-v0"


def test_registration_is_idempotent():
    assert register_envs() == []
    for env_id in ENV_IDS:
        assert env_id in gym.registry


@pytest.mark.parametrize(
    "env_id, steps",
    [
        (REACH, 50),
        ("TrossenMujoco/WXAIPushGoal-v0", 100),
        ("TrossenMujoco/StationaryAITransferCube-v0", 600),
    ],
)
def test_max_episode_steps(env_id, steps):
    assert gym.spec(env_id).max_episode_steps == steps


def test_time_limit_truncates(make_env):
    env = make_env(REACH, max_episode_steps=3)
    env.reset(seed=0)
    flags = [env.step(env.action_space.sample())[3] for _ in range(3)]
    assert flags == [False, False, True]


def test_state_observation(make_env):
    env = make_env(REACH)
    obs, info = env.reset(seed=0)
    # arm_qpos 6, arm_qvel 6, gripper 1, ee_pos 3, goal 3, goal_delta 3
    assert obs.shape == (22,) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    assert info == {
        "is_success": False,
        "goal_distance": info["goal_distance"],
        "safety_clipped": False,
        "safety_links": "",
    }


def test_pixels_and_render(make_env):
    env = make_env(
        REACH,
        obs_type="pixels",
        render_mode="rgb_array",
        width=32,
        height=24,
        cameras=["overview", "cam"],
    )
    obs, _ = env.reset(seed=0)
    assert obs.shape == (24, 64, 3) and obs.dtype == np.uint8 and obs.std() > 0
    frame = env.render()
    assert frame.shape == (24, 64, 3)
    env = make_env(REACH, obs_type="pixels_state", width=32, height=24)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"pixels", "state"} and obs["pixels"].shape == (24, 32, 3)


@pytest.mark.parametrize("env_id", [PUSH, TRANSFER])
def test_shadows_option(make_env, env_id):
    on = make_env(env_id).unwrapped.scene.model
    assert on.light_castshadow.sum() == 1  # the key light
    env = make_env(env_id, obs_type="pixels", width=32, height=24, shadows=False)
    assert not env.unwrapped.scene.model.light_castshadow.any()
    obs, _ = env.reset(seed=0)
    assert obs.shape == (24, 32, 3) and obs.std() > 0


def test_menagerie_visual_option(make_env, fake_menagerie):
    env = make_env(PUSH, obs_type="pixels", width=32, height=24, visual="menagerie")
    model = env.unwrapped.scene.model
    assert "menagerie_link_2" in [model.mesh(i).name for i in range(model.nmesh)]
    obs, _ = env.reset(seed=0)
    assert obs.shape == (24, 32, 3) and obs.std() > 0


def test_menagerie_visual_needs_a_checkout(make_env, monkeypatch):
    monkeypatch.delenv("TROSSEN_MENAGERIE_DIR", raising=False)
    with pytest.raises(UserError, match="TROSSEN_MENAGERIE_DIR") as err:
        make_env(PUSH, visual="menagerie")
    assert "\n" not in str(err.value)


def test_unknown_camera_lists_cameras(make_env):
    with pytest.raises(UserError, match="overview"):
        make_env(REACH, obs_type="pixels", cameras=["top"])


def test_human_render_without_display_warns(make_env, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.warns(UserWarning, match="needs a display"):
        env = make_env(REACH, render_mode="human")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.render() is None


def test_config_override_through_make(make_env):
    env = make_env(
        REACH, success_tolerance=0.2, target_low=[0.3, 0.0, 0.2], target_high=[0.3, 0.0, 0.2]
    )
    _, info = env.reset(seed=0)
    assert env.unwrapped.config["success_tolerance"] == 0.2
    np.testing.assert_allclose(env.unwrapped.task.desired_goal(), [0.3, 0.0, 0.2])
    assert info["is_success"] is (info["goal_distance"] < 0.2)


def test_unknown_kwarg_lists_options_and_config_keys(make_env):
    with pytest.raises(UserError) as err:
        make_env(REACH, obs_tpye="pixels")
    msg = str(err.value)
    assert "obs_tpye" in msg and "obs_type" in msg and "success_tolerance" in msg


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"obs_type": "rgb"}, "pixels_state"),
        ({"render_mode": "window"}, "rgb_array"),
        ({"task": "stack"}, "pick_place"),
        ({"visual": "pretty"}, "menagerie, own"),
        ({"shadows": "no"}, "True or False"),
    ],
)
@pytest.mark.filterwarnings("ignore:.*render_mode")
def test_bad_choices_are_user_errors(make_env, kwargs, match):
    with pytest.raises(UserError, match=match):
        make_env(REACH, **kwargs)


def test_reset_seed_seeds_spaces(make_env):
    env = make_env("TrossenMujoco/WXAIPushGoal-v0")
    env.reset(seed=3)
    a1, o1 = env.action_space.sample(), env.observation_space.sample()
    env.reset(seed=3)
    a2, o2 = env.action_space.sample(), env.observation_space.sample()
    np.testing.assert_array_equal(a1, a2)
    np.testing.assert_array_equal(o1["desired_goal"], o2["desired_goal"])


def test_step_before_reset(make_env):
    env = make_env(REACH, disable_env_checker=True)
    with pytest.raises((UserError, gym.error.ResetNeeded)):
        env.step(env.action_space.sample())


def test_close_twice(make_env):
    env = make_env(REACH, stepping="realtime")
    env.reset(seed=0)
    env.close()
    env.close()


def test_randomize_is_off_by_default(make_env):
    env = make_env(REACH)
    _, info = env.reset(seed=0)
    assert "randomization" not in info and env.unwrapped.sampler.randomize is False


def test_randomize_same_seed_same_scene(make_env):
    kwargs = dict(obs_type="pixels_state", width=40, height=32, randomize=True)
    env = make_env("TrossenMujoco/WXAIPush-v0", **kwargs)
    other = make_env("TrossenMujoco/WXAIPush-v0", **kwargs)
    plain = make_env("TrossenMujoco/WXAIPush-v0", obs_type="pixels_state", width=40, height=32)
    for e in (env, other, plain):
        e.reset(seed=3)  # the first image of a renderer is not compared
    a, info_a = env.reset(seed=4)
    b, info_b = other.reset(seed=4)
    c, info_c = env.reset(seed=5)
    p, _ = plain.reset(seed=4)
    assert info_a["randomization"] == info_b["randomization"] != info_c["randomization"]
    np.testing.assert_array_equal(a["pixels"], b["pixels"])
    assert not np.array_equal(a["pixels"], c["pixels"])
    assert not np.array_equal(a["pixels"], p["pixels"])
    # the task's episode (cube and goal) is the one of the plain env
    other.reset(seed=4)
    t, q = other.unwrapped.task, plain.unwrapped.task
    np.testing.assert_array_equal(t.cube_pos(), q.cube_pos())
    np.testing.assert_array_equal(t.desired_goal(), q.desired_goal())


def test_randomization_section_overrides_through_make(make_env):
    env = make_env(REACH, randomize=True, randomization={"camera": {"enabled": False}})
    _, info = env.reset(seed=0)
    assert "camera" not in info["randomization"] and "lights" in info["randomization"]


def test_human_viewer_closes_at_exit_under_xvfb(tmp_path):
    """A human-render env (viewer window) never closed exits cleanly: its viewer is closed,
    and its threads joined, before the interpreter tears down (it used to segfault)."""
    import os
    import shutil
    import subprocess
    import sys
    import time
    from pathlib import Path

    if not shutil.which("Xvfb"):
        pytest.skip("Xvfb is needed (apt-get install xvfb)")
    num = next((n for n in range(140, 160) if not Path(f"/tmp/.X{n}-lock").exists()), None)
    if num is None:
        pytest.skip("no free X display number")
    xvfb = subprocess.Popen(
        ["Xvfb", f":{num}", "-screen", "0", "640x480x24"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    code = (
        "import gymnasium as gym, trossen_arm_mujoco\n"
        f"env = gym.make('{REACH}', render_mode='human')\n"
        "env.reset(seed=0)\n"
        "for _ in range(3): env.step(env.action_space.sample())\n"
        "print('stepped')\n"  # and no env.close()
    )
    try:
        time.sleep(1.5)
        env = {**os.environ, "DISPLAY": f":{num}", "MUJOCO_GL": "egl"}
        proc = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env
        )
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=10)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    assert "stepped" in proc.stdout
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr
