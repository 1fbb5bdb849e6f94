"""Evaluation under variation: ``eval --randomize`` / ``--randomization FILE``, the served
kit's ``--randomize`` and the wire's start record: same seed, same scene, each episode's
record kept."""

from __future__ import annotations

import json
import socket

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.env import KitPolicyEnv
from trossen_arm_mujoco.eval.runner import EpisodeRunner, EvalSettings
from trossen_arm_mujoco.tasks.config import read_randomization
from trossen_arm_mujoco.twin.episode_control import EpisodeControl
from trossen_arm_mujoco.twin.kit_world import KitWorld

TASK = "sim_transfer_cube"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _records(env: KitPolicyEnv, seed: int):
    obs, _ = env.reset(seed=seed)
    return env.randomization, obs["agent_pos"].copy()


def test_same_seed_same_scene_and_the_nominal_env_has_no_record():
    env = KitPolicyEnv(TASK, randomize=True, render_mode=None)
    nominal = KitPolicyEnv(TASK, render_mode=None)
    try:
        first, pos = _records(env, 5)
        again, pos_again = _records(env, 5)
        other, _ = _records(env, 6)
        assert first is not None and first == again
        np.testing.assert_array_equal(pos, pos_again)  # the arms' start noise too
        assert other != first
        assert json.loads(json.dumps(first)) == first  # JSON as it is stored
        nominal.reset(seed=5)
        assert nominal.randomization is None
    finally:
        env.close()
        nominal.close()


def test_a_randomization_file_replaces_the_tasks_kinds_and_is_checked(tmp_path):
    only_lights = tmp_path / "lights.yaml"
    only_lights.write_text(
        "randomization:\n"
        + "".join(
            f"  {k}: {{enabled: false}}\n"
            for k in (
                "table",
                "objects",
                "friction",
                "object_mass",
                "joint_damping",
                "camera",
                "joint_noise",
            )
        )
        + "  lights: {enabled: true, direction_deg: 30.0}\n"
    )
    section = read_randomization(only_lights)
    env = KitPolicyEnv(TASK, randomization=section, render_mode=None)
    try:
        env.reset(seed=1)
        assert env.randomize and set(env.randomization) >= {"lights"}
        assert "camera" not in env.randomization or not env.randomization["camera"]
    finally:
        env.close()
    bad = tmp_path / "bad.yaml"
    bad.write_text("lightz: {enabled: true}\n")
    with pytest.raises(UserError, match="unknown randomization kind 'lightz'") as e:
        read_randomization(bad)
    assert "\n" not in str(e.value)
    out_of_bounds = tmp_path / "far.yaml"
    out_of_bounds.write_text("camera: {position: 5.0}\n")
    with pytest.raises(UserError, match="camera.position"):
        read_randomization(out_of_bounds)


def test_the_runner_keeps_each_episodes_record(tmp_path):
    settings = EvalSettings(
        policy="scripted",
        task=TASK,
        num_episodes=1,
        seed=3,
        episode_length=5,
        output_dir=str(tmp_path),
        randomize=True,
    )
    runner = EpisodeRunner(settings)
    try:
        score, _ = runner.run(0)
        assert score.analysis["randomization"] == runner.env.randomization
    finally:
        runner.env.close()
    assert settings.run_block()["randomize"] is True


def test_the_served_kit_reports_and_applies_a_record():
    world = KitWorld(TASK, randomize=True)
    plain = KitWorld(TASK)
    try:
        drawn = world.scene_randomization
        assert drawn is not None
        control = EpisodeControl(plain, port=free_port())  # not started: requests by hand
        reply = control._apply({"cmd": "start", "seed": 4, "randomization": drawn})
        assert reply["randomization"] == drawn  # the nominal kit showed the client's scene
        assert plain.scene_randomization == drawn
        reply = control._apply({"cmd": "start", "seed": 4})
        assert "randomization" not in reply  # and back to nominal
        with pytest.raises(UserError, match="randomization must be a record"):
            control._apply({"cmd": "start", "seed": 4, "randomization": [1, 2]})
        control.stop()
    finally:
        world.close()
        plain.close()


def test_the_levels_nominal_train_and_hard():
    from trossen_arm_mujoco.tasks import registry
    from trossen_arm_mujoco.tasks.randomization_levels import harder, level_section

    assert level_section(None, TASK) == (False, None)
    assert level_section("nominal", TASK) == (False, None)
    assert level_section("train", TASK) == (True, None)
    randomize, hard = level_section("hard", TASK)
    train = registry.load(TASK).load_config()["randomization"]
    assert randomize and hard == harder(train)
    assert hard["camera"]["position"] == pytest.approx(3 * train["camera"]["position"])
    assert hard["camera"]["orientation_deg"] == pytest.approx(
        3 * train["camera"]["orientation_deg"]
    )
    assert hard["lights"]["direction_deg"] >= 35.0
    lo, hi = hard["friction"]["scale"]
    assert lo < train["friction"]["scale"][0] and hi > train["friction"]["scale"][1]
    with pytest.raises(UserError, match="unknown randomization level 'harder'"):
        level_section("harder", TASK)
    env = KitPolicyEnv(TASK, randomization=hard, render_mode=None)
    try:
        env.reset(seed=2)
        offsets = env.randomization["camera"]
        assert offsets  # drawn from the wider ranges, within the schema's bounds
    finally:
        env.close()
