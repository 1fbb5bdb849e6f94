"""The arm controller's checks in every in-process evaluation: a policy's actions reach the
arms as on the real kit, and a command the controller would refuse ends the episode as a
failure naming the joint, the reason, the limit and the step."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.eval.env import KitPolicyEnv

JUMP_POLICY = '''
import numpy as np

_steps = {"n": 0}


def reset():
    _steps["n"] = 0


def act(obs):
    """Hold still, then at step 5 ask joint_1 of the left arm to jump by 1 rad."""
    q = np.asarray(obs["agent_pos"], dtype=float).copy()
    _steps["n"] += 1
    if _steps["n"] == 6:
        q[1] += 1.0
    return q
'''


@pytest.fixture
def jump_module(tmp_path, monkeypatch):
    (tmp_path / "jump_policy.py").write_text(textwrap.dedent(JUMP_POLICY))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "jump_policy:act"
    sys.modules.pop("jump_policy", None)


def _run(args, capsys):
    rc = cli.main(["eval", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_a_joint_jump_faults_in_process_naming_joint_limit_and_step(tmp_path, jump_module, capsys):
    out_dir = tmp_path / "eval"
    rc, out, err = _run(
        [
            "--policy",
            jump_module,
            "--num_episodes",
            "1",
            "--episode_length",
            "20",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    (episode,) = info["per_episode"]
    assert episode["success"] is False and episode["steps"] == 6  # ended at the fault
    fault = episode["fault"]
    assert fault["joint"] == "left_joint_1" and fault["kind"] == "speed"
    assert fault["limit"] == 3.375 and fault["asked"] > 15 and fault["step"] == 5
    assert info["controller"]["faults_by_joint"] == {"left_joint_1": 1}
    assert info["controller"]["faults_by_reason"] == {"speed": 1}
    assert info["controller"]["peak_speed_fraction"]["left_joint_1"] > 4.9
    rollouts = json.loads((out_dir / "rollouts.json").read_text())
    assert rollouts["episodes"][0]["fault"]["step"] == 5
    assert rollouts["aggregated"]["controller_faults"] == {"left_joint_1 speed": 1}
    assert "arm controller checks: on, 1 episode(s) faulted (by joint: left_joint_1 1" in out


def test_checks_off_gives_the_unconstrained_run_and_both_shows_them_side_by_side(
    tmp_path, jump_module, capsys
):
    out_dir = tmp_path / "eval"
    rc, out, err = _run(
        [
            "--policy",
            jump_module,
            "--num_episodes",
            "1",
            "--episode_length",
            "20",
            "--output_dir",
            str(out_dir),
            "--controller_checks",
            "both",
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["controller"]["faulted_episodes"] == 1
    free = info["unconstrained"]
    assert free["controller"]["checks"] is False and free["controller"]["faulted_episodes"] == 0
    assert free["aggregated"]["n_episodes"] == 1
    assert "without the controller's checks: 0.0%" in out
    rc, out, err = _run(
        [
            "--policy",
            jump_module,
            "--num_episodes",
            "1",
            "--episode_length",
            "20",
            "--output_dir",
            str(out_dir),
            "--overwrite",
            "--controller_checks",
            "off",
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["per_episode"][0]["fault"] is None and info["per_episode"][0]["steps"] == 20
    assert info["controller"]["checks"] is False and info["run"]["controller_checks"] is False
    assert "arm controller checks: off" in out


def test_the_scripted_policy_passes_with_the_checks_on(tmp_path, capsys):
    out_dir = tmp_path / "eval"
    rc, out, err = _run(
        ["--policy", "scripted", "--num_episodes", "10", "--output_dir", str(out_dir)], capsys
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["aggregated"]["pc_success"] >= 90.0
    assert info["controller"]["faulted_episodes"] == 0
    assert max(info["controller"]["peak_speed_fraction"].values()) < 1.1


def test_a_non_finite_action_is_the_controllers_fault_and_success_needs_no_fault():
    env = KitPolicyEnv(image_size=(24, 32))
    try:
        obs, info = env.reset(seed=0)
        assert info["is_success"] is False
        action = np.asarray(obs["agent_pos"], dtype=float).copy()
        action[9] = np.nan
        _, _, terminated, truncated, info = env.step(action)
        assert terminated and not truncated and info["is_success"] is False
        assert info["fault"]["kind"] == "non-finite" and info["fault"]["joint"] == "right_joint_2"
        assert info["fault"]["step"] == 0
    finally:
        env.close()


def test_the_wire_backend_refuses_checks_off(capsys):
    rc = cli.main(
        ["eval", "--policy", "scripted", "--backend", "wire", "--controller_checks", "off"]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert "error: --controller_checks off is for --backend sim" in err


def _fake_checkpoint(folder, with_env_state: bool):
    folder.mkdir()
    inputs = {
        "observation.state": {"type": "STATE", "shape": [14]},
        "observation.images.cam_high": {"type": "VISUAL", "shape": [3, 24, 32]},
    }
    if with_env_state:
        inputs["observation.environment_state"] = {"type": "ENV", "shape": [7]}
    config = {
        "type": "act",
        "input_features": inputs,
        "output_features": {"action": {"type": "ACTION", "shape": [14]}},
    }
    (folder / "config.json").write_text(json.dumps(config))
    return folder


@pytest.mark.parametrize("backend", ["sim", "wire"])
def test_a_checkpoint_observing_the_cube_pose_is_sim_only_on_both_backends(tmp_path, backend):
    from trossen_arm_mujoco.scripts.eval_policy import _settings, build_parser, deployment

    for with_env, expected in ((True, True), (False, False)):
        ckpt = _fake_checkpoint(tmp_path / f"ckpt_{with_env}_{backend}", with_env)
        args = build_parser().parse_args(["--policy", str(ckpt), "--backend", backend])
        settings, _ = _settings(args)
        block = deployment(settings, backend)
        assert block["sim_only"] is expected
        if expected:
            assert "observation.environment_state" in block["why"]
            assert ("not a deployment rehearsal" in block["why"]) is (backend == "wire")
    assert deployment(settings, "sim")["why"].startswith("the checkpoint observes only")
