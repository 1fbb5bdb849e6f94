"""``trossen-mujoco eval`` of the Mobile AI task (``mobile_pick_place``) in the ``mobileai``
layout: the env's spaces, the base's commands (clipped and counted, never a fault; a
non-finite one is a fault), the scripted and a module:function policy through the CLI with
the task's stages in eval_info.json, a mobileai checkpoint's features, and the one-line
refusals (another layout, --backend wire, a task eval does not take)."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import runner
from trossen_arm_mujoco.eval.env import KitPolicyEnv, feature_spec, task_layouts
from trossen_arm_mujoco.eval.lerobot_policy import check_checkpoint
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT
from trossen_arm_mujoco.scripts.eval_policy import _layout_for

TASK = "mobile_pick_place"
STAGES = ("at_table", "touched", "lifted", "placed")


@pytest.fixture(scope="module")
def env():
    made = KitPolicyEnv(TASK, layout="mobileai", episode_length=20, render_mode=None)
    yield made
    made.close()


def _eval(args, capsys):
    rc = cli.main(["eval", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _one_line_error(rc, out, err) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and out == "" and len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _hold(obs, x_vel=0.0, theta_vel=0.0) -> np.ndarray:
    """The arms held at their measured positions, then the base's command."""
    return np.concatenate([obs["agent_pos"][:14], [x_vel, theta_vel]])


def test_the_mobileai_spaces_are_the_arms_then_the_base(env):
    assert env.layout is MOBILEAI_LAYOUT and task_layouts(TASK) == ("mobileai",)
    assert env.action_space.shape == (16,)
    np.testing.assert_array_equal(env.action_space.low[14:], [-1.0, -1.0])
    np.testing.assert_array_equal(env.action_space.high[14:], [1.0, 1.0])
    for key in ("agent_pos", "velocity"):
        assert env.observation_space[key].shape == (16,)
    assert env.observation_space["environment_state"].shape == (7,)  # the cube
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    np.testing.assert_allclose(obs["agent_pos"][14:], 0.0, atol=1e-3)  # at rest
    assert info == {"is_success": False, "stage": info["stage"]}
    spec = feature_spec(TASK, ("cam_high",), (24, 32), "mobileai")
    assert spec["action"][2] == (16,) and spec["agent_pos"][2] == (16,)
    assert spec["observation.images.cam_high"][2] == (24, 32, 3)


def test_a_base_command_drives_the_base_and_beyond_its_limits_is_clipped_and_counted(env):
    obs, _ = env.reset(seed=0)
    for _ in range(10):
        obs, _, terminated, _, info = env.step(_hold(obs, x_vel=0.3))
        assert not terminated and "fault" not in info
    assert info["base_clipped"] == 0 and obs["agent_pos"][14] > 0.1  # measured x.vel
    obs, _, terminated, _, info = env.step(_hold(obs, x_vel=2.5, theta_vel=-4.0))
    assert not terminated and "fault" not in info and info["base_clipped"] == 1
    env.reset(seed=0)  # counted per episode
    _, _, _, _, info = env.step(_hold(obs))
    assert info["base_clipped"] == 0


def test_a_non_finite_base_command_is_a_fault_with_the_checks_on(env):
    obs, _ = env.reset(seed=1)
    _, _, terminated, _, info = env.step(_hold(obs, x_vel=np.nan))
    assert terminated and info["fault"]["joint"] == "x.vel"
    assert info["fault"]["kind"] == "non-finite" and not info["is_success"]
    off = KitPolicyEnv(TASK, layout="mobileai", render_mode=None, controller_checks=False)
    try:
        obs, _ = off.reset(seed=1)
        with pytest.raises(UserError, match="NaN or inf"):
            off.step(_hold(obs, theta_vel=np.inf))
    finally:
        off.close()


def test_other_layouts_and_other_tasks_are_refused_in_one_line():
    with pytest.raises(UserError, match="takes the layouts mobileai, not 'kit14'"):
        KitPolicyEnv(TASK, render_mode=None)
    assert task_layouts("reach") == ("widowxai",)  # a single arm's task: eval.arm_env
    with pytest.raises(UserError, match="takes the layouts widowxai, not 'kit14'"):
        KitPolicyEnv("reach", render_mode=None)
    assert _layout_for(TASK, None, None) == "mobileai"
    assert _layout_for(TASK, None, "vendor16") == "mobileai"  # a 16-value checkpoint
    assert _layout_for("sim_transfer_cube", None, None) == "kit14"


def test_a_checkpoint_of_the_mobileai_export_is_accepted_when_its_features_match(tmp_path):
    env = KitPolicyEnv(
        TASK, layout="mobileai", cam_names=["cam_high"], image_size="24x32", render_mode=None
    )
    try:

        def checkpoint(state: int, action: int):
            folder = tmp_path / f"ckpt_{state}_{action}"
            folder.mkdir()
            config = {
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [state]},
                    "observation.images.cam_high": {"type": "VISUAL", "shape": [3, 24, 32]},
                },
                "output_features": {"action": {"type": "ACTION", "shape": [action]}},
            }
            (folder / "config.json").write_text(json.dumps(config))
            return folder

        check_checkpoint(checkpoint(16, 16), env)  # the mobileai export's shapes
        with pytest.raises(UserError, match=r"observation.state \[14\]"):
            check_checkpoint(checkpoint(14, 16), env)
        with pytest.raises(UserError, match=r"action \[14\]"):
            check_checkpoint(checkpoint(16, 14), env)
    finally:
        env.close()


def test_wire_backend_refuses_the_mobile_task_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner.EpisodeRunner, "run", lambda self, i: pytest.fail("ran"))
    rc, out, err = _eval(
        [
            "--task_name",
            TASK,
            "--policy",
            "scripted",
            "--backend",
            "wire",
            "--output_dir",
            str(tmp_path / "e"),
        ],
        capsys,
    )
    line = _one_line_error(rc, out, err)
    assert "--backend wire drives the served Stationary AI kit" in line
    assert "--backend sim" in line


def test_eval_of_a_task_it_does_not_take_is_one_line(tmp_path, capsys):
    rc, out, err = _eval(
        ["--task_name", "reach", "--policy", "scripted", "--output_dir", str(tmp_path / "e")],
        capsys,
    )
    assert "task 'reach' has no scripted policy" in _one_line_error(rc, out, err)


def test_a_function_policy_drives_the_mobile_task(tmp_path, capsys, monkeypatch):
    module = tmp_path / "mobile_drive_policy.py"
    module.write_text(
        textwrap.dedent("""
        import numpy as np

        def act(observation):
            # arms held where they are, the base forward at twice its limit (clipped)
            return np.concatenate([observation["agent_pos"][:14], [2.0, 0.0]])
    """)
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("mobile_drive_policy", None)
    out_dir = tmp_path / "eval"
    rc, _, err = _eval(
        [
            "--task_name",
            TASK,
            "--policy",
            "mobile_drive_policy:act",
            "--num_episodes",
            "1",
            "--episode_length",
            "40",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["run"]["layout"] == "mobileai"
    assert tuple(info["aggregated"]["stages"]) == STAGES
    episode = info["per_episode"][0]
    assert episode["fault"] is None and not episode["success"]
    rollouts = json.loads((out_dir / "rollouts.json").read_text())
    assert rollouts["episodes"][0]["base_clipped_commands"] == 40


def test_the_scripted_policy_places_the_cube_through_eval(tmp_path, capsys):
    out_dir = tmp_path / "eval"
    rc, _, err = _eval(
        [
            "--task_name",
            TASK,
            "--policy",
            "scripted",
            "--num_episodes",
            "1",
            "--seed",
            "7",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    episode = info["per_episode"][0]
    assert episode["success"] and episode["fault"] is None
    assert episode["stages"] == dict.fromkeys(STAGES, True)
    assert info["controller"]["faulted_episodes"] == 0
