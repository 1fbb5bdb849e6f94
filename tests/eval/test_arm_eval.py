"""``trossen-mujoco eval`` of the single WidowX AI arm's tasks (push, pick_place) in the
arm's 7-value layout (``widowxai``, ``eval.arm_env``): the env's spaces and seeds, the
scripted policy through the CLI scored by the task, a module:function policy through the
controller's checks (a jump is a speed fault, labelled by the arm's joint), a 7-value
checkpoint's features, and the one-line refusals."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.arm_env import ArmPolicyEnv
from trossen_arm_mujoco.eval.arm_tasks import ARM_LAYOUT_NAME, arm_names
from trossen_arm_mujoco.eval.env import feature_spec, task_layouts
from trossen_arm_mujoco.eval.lerobot_policy import check_checkpoint, checkpoint_features
from trossen_arm_mujoco.real.arm_controller import ARM_SIDES, KitController
from trossen_arm_mujoco.scripts.eval_policy import _layout_for

TASK = "pick_place"
LABELS = [*(f"joint_{i}" for i in range(6)), "gripper"]


@pytest.fixture(scope="module")
def env():
    made = ArmPolicyEnv(TASK, episode_length=20, render_mode=None)
    yield made
    made.close()


def _eval(args, capsys):
    rc = cli.main(["eval", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_the_single_arm_spaces_are_its_seven_values(env):
    assert set(arm_names()) >= {"push", "pick_place"}
    assert task_layouts(TASK) == (ARM_LAYOUT_NAME,) and _layout_for(TASK, None, None) == "widowxai"
    assert env.action_space.shape == (7,)
    for key in ("agent_pos", "velocity"):
        assert env.observation_space[key].shape == (7,)
    # the cube, then the goal (as export --sim_features writes them)
    assert env.observation_space["environment_state"].shape == (10,)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    assert obs["goal"].shape == (3,) and info["is_success"] is False
    np.testing.assert_array_equal(obs["environment_state"][7:], obs["goal"])
    x, y, z = obs["goal"]  # the episode's goal in words: a checkpoint's instruction
    assert env.task_description.endswith(f"({x:.3f}, {y:.3f}, {z:.3f}) m")
    again, _ = env.reset(seed=3)  # same seed, same episode
    for key in ("agent_pos", "environment_state", "goal"):
        np.testing.assert_array_equal(obs[key], again[key])
    other, _ = env.reset(seed=4)
    assert not np.array_equal(obs["environment_state"], other["environment_state"])
    spec = feature_spec(TASK, ("cam",), (24, 32), "widowxai")
    assert spec["action"][2] == (7,) and spec["agent_pos"][2] == (7,)
    assert spec["environment_state"][2] == (10,)
    assert spec["observation.images.cam"][2] == (24, 32, 3)


def test_holding_still_is_no_fault_and_a_jump_is_a_speed_fault_of_the_arms_joint(env):
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, _, terminated, _, info = env.step(obs["agent_pos"])
        assert not terminated and "fault" not in info
    assert set(env.controller.peak_fractions()) == set(LABELS)
    jump = obs["agent_pos"].astype(float) + np.array([0.8, 0, 0, 0, 0, 0, 0])
    _, _, terminated, _, info = env.step(jump)
    assert terminated and info["is_success"] is False
    assert info["fault"]["joint"] == "joint_0" and info["fault"]["kind"] == "speed"
    assert info["fault"]["step"] == 3


def test_one_arm_controller_labels_its_values_without_a_side():
    ctl = KitController(sides=ARM_SIDES)
    assert ctl.labels == tuple(LABELS) and ctl.peak_fraction.shape == (7,)
    ctl.reset(np.zeros(7))
    ctl.command(np.full(7, np.nan), 0.06)
    _, fault = ctl.tick(0.002)
    assert fault is not None and fault.joint == "joint_0" and not fault.reason.startswith("_")


@pytest.mark.parametrize(("task", "fps"), [("push", 50), ("pick_place", 50), ("pick_place", 30)])
def test_scripted_policy_through_the_cli_is_scored_by_the_task(task, fps, tmp_path, capsys):
    """At the task's 50 Hz and at the plugin's 30 Hz (the default export's rate: physics
    steps of 1/510 s divide its period)."""
    out_dir = tmp_path / "eval"
    args = ["--policy", "scripted", "--task_name", task, "--num_episodes", "1"]
    rc, out, err = _eval([*args, "--fps", str(fps), "--output_dir", str(out_dir)], capsys)
    assert rc == 0, err
    assert out.splitlines()[0].startswith(f"{task}: 1/1 succeeded, 100.0%")
    assert "arm controller checks: on, 0 faults" in out
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["run"]["layout"] == "widowxai" and info["per_episode"][0]["success"]
    assert info["per_episode"][0]["steps"] == 7 * fps  # the recording's 7 s
    assert info["per_episode"][0]["fault"] is None
    peak = info["controller"]["peak_speed_fraction"]
    assert list(peak) == LABELS and 0 < max(peak.values()) < 1
    rollouts = json.loads((out_dir / "rollouts.json").read_text())
    end = rollouts["episodes"][0]["end"]
    assert rollouts["episodes"][0]["success"] and list(end) == ["gripper_gap_m"]


def test_a_function_policy_acts_in_the_seven_values(tmp_path, capsys, monkeypatch):
    (tmp_path / "arm_policies.py").write_text(
        textwrap.dedent(
            """
            import numpy as np

            def hold(obs):
                assert obs["agent_pos"].shape == (7,) and obs["goal"].shape == (3,)
                return obs["agent_pos"]

            def jump(obs):
                return obs["agent_pos"] + np.array([0, 0.9, 0, 0, 0, 0, 0])
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "arm_policies", raising=False)
    base = ["--task_name", TASK, "--num_episodes", "1", "--episode_length", "5"]
    rc, out, err = _eval(
        [*base, "--policy", "arm_policies:hold", "--output_dir", str(tmp_path / "h")], capsys
    )
    assert rc == 0, err
    assert out.startswith(f"{TASK}: 0/1 succeeded") and "on, 0 faults" in out
    rc, out, err = _eval(
        [*base, "--policy", "arm_policies:jump", "--output_dir", str(tmp_path / "j")], capsys
    )
    assert rc == 0, err
    assert "1 episode(s) faulted (by joint: joint_1 1; by reason: speed 1)" in out
    info = json.loads((tmp_path / "j" / "eval_info.json").read_text())
    assert info["per_episode"][0]["steps"] == 1


def test_a_seven_value_checkpoint_is_read_as_the_arms_layout(tmp_path):
    env = ArmPolicyEnv(TASK, cam_names=["cam"], image_size="24x32", render_mode=None)
    try:

        def checkpoint(state: int, action: int):
            folder = tmp_path / f"ckpt_{state}_{action}"
            folder.mkdir()
            config = {
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [state]},
                    "observation.images.cam": {"type": "VISUAL", "shape": [3, 24, 32]},
                },
                "output_features": {"action": {"type": "ACTION", "shape": [action]}},
            }
            (folder / "config.json").write_text(json.dumps(config))
            return folder

        good = checkpoint(7, 7)
        assert checkpoint_features(good)["layout"] == "widowxai"
        check_checkpoint(good, env)
        with pytest.raises(UserError, match=r"observation.state \[14\]"):
            check_checkpoint(checkpoint(14, 7), env)
        with pytest.raises(UserError, match=r"action \[14\]"):
            check_checkpoint(checkpoint(7, 14), env)
    finally:
        env.close()


def test_other_layouts_and_a_task_without_a_scripted_policy_are_one_line(tmp_path, capsys):
    with pytest.raises(UserError, match="takes the layout widowxai"):
        ArmPolicyEnv(TASK, layout="kit14", render_mode=None)
    with pytest.raises(UserError, match="not a single-arm task"):
        ArmPolicyEnv("sim_transfer_cube", render_mode=None)
    rc, out, err = _eval(
        ["--task_name", TASK, "--policy", "scripted", "--layout", "kit14"]
        + ["--output_dir", str(tmp_path / "e")],
        capsys,
    )
    assert rc == 2 and out == "" and "takes the layout widowxai" in err


def test_wire_takes_one_address_for_the_single_arm(tmp_path, capsys):
    rc, out, err = _eval(
        ["--task_name", TASK, "--policy", "scripted", "--backend", "wire"]
        + ["--right_ip", "127.0.0.188", "--output_dir", str(tmp_path / "e")],
        capsys,
    )
    assert rc == 2 and out == "" and "give it with --left_ip" in err
