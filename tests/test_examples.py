"""``examples/``: each runs to completion where its requirements are installed, and otherwise
says in one line what is missing (exit 2). Loopback addresses 127.0.0.101 .. 127.0.0.109."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PLUGIN_EXAMPLE = REPO / "examples" / "lerobot_plugin_on_served_kit.py"


def run_example(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(PLUGIN_EXAMPLE), *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )


def test_plugin_example_drives_the_served_kit_or_says_what_is_missing():
    proc = run_example("--left_ip", "127.0.0.101", "--right_ip", "127.0.0.102")
    if importlib.util.find_spec("lerobot_robot_trossen") is None:
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
        assert proc.stderr.startswith("error: Trossen's LeRobot plugin is not importable")
        assert "pip install --no-deps" in proc.stderr
    else:  # the plugin is there: the whole run, through LeRobot's robot factory
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "loop:" in proc.stdout and "disconnect:" in proc.stdout


def test_plugin_example_refuses_addresses_beyond_loopback():
    for ip in ("192.168.1.2", "not-an-address"):
        proc = run_example("--left_ip", ip)
        assert proc.returncode == 2
        assert proc.stderr == f"error: {ip} is not a loopback address: use 127.0.0.0/8\n"


# -- examples/my_trossen_task: a task in its own package (docs/writing-a-task.md) -------------
TASK_PACKAGE = REPO / "examples" / "my_trossen_task"


def _require_task_package() -> None:
    if importlib.util.find_spec("my_trossen_task") is None:
        raise AssertionError(
            "the example task package is not installed: "
            f"{sys.executable} -m pip install -e {TASK_PACKAGE.relative_to(REPO)} "
            "(tools/run_tests.sh does)"
        )


def _cli(*args: str, cwd: Path) -> str:
    proc = subprocess.run(
        [sys.executable, "-m", "trossen_arm_mujoco.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


@pytest.mark.once
def test_the_example_task_package_records_exports_and_evaluates(tmp_path):
    _require_task_package()
    out = _cli(
        "record",
        "--task_name",
        "lift_puck",
        "--data_dir",
        str(tmp_path / "eps"),
        "--num_episodes",
        "2",
        "--cam_names",
        "none",
        cwd=tmp_path,
    )
    assert "Success: 2 / 2" in out, out
    out = _cli(
        "export",
        "--data_dir",
        str(tmp_path / "eps"),
        "--output",
        str(tmp_path / "ds"),
        "--repo_id",
        "me/lift_puck",
        cwd=tmp_path,
    )
    assert "exported 2 episode(s)" in out, out
    info = json.loads((tmp_path / "ds" / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2
    _cli(
        "eval",
        "--policy",
        "scripted",
        "--task_name",
        "lift_puck",
        "--num_episodes",
        "2",
        "--cam_names",
        "none",
        "--output_dir",
        str(tmp_path / "ev"),
        cwd=tmp_path,
    )
    agg = json.loads((tmp_path / "ev" / "eval_info.json").read_text())["aggregated"]
    assert agg["pc_success"] == 100.0 and agg["stages"] == {"touched": 100.0, "lifted": 100.0}


@pytest.mark.once
def test_the_example_task_packages_own_tests_pass():
    _require_task_package()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=TASK_PACKAGE,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest
def test_lerobot_eval_runs_the_example_package_task(tmp_path):
    """``lerobot-eval --env.type=trossen --env.task=lift_puck``: LeRobot's env plugin takes the
    task of an installed package (the example, installed next to LeRobot by
    tools/run_tests.sh). Tiny: 2 recorded episodes of 30 steps without cameras, a state-only
    ACT trained 2 steps with lerobot-train, 1 evaluated episode of 10 steps."""
    _require_task_package()
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python or not Path(python).is_file():
        pytest.skip("TROSSEN_LEROBOT_PYTHON is not set to a Python with LeRobot (.ci/run sets it)")
    probe = subprocess.run(
        [python, "-c", "import my_trossen_task, lerobot_env_trossen"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert probe.returncode == 0, (
        f"the example task package and the env plugin are not importable next to LeRobot: "
        f"{python} -m pip install -e {TASK_PACKAGE.relative_to(REPO)} "
        f"-e plugins/lerobot_env_trossen (tools/run_tests.sh does): {probe.stderr[-500:]}"
    )
    record = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.cli",
            "record",
            "--task_name",
            "lift_puck",
            "--data_dir",
            str(tmp_path / "eps"),
            "--num_episodes",
            "2",
            "--episode_len",
            "30",
            "--cam_names",
            "none",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert record.returncode in (0, 1), record.stderr  # 30 steps lift nothing: episodes kept
    _cli(
        "export",
        "--data_dir",
        str(tmp_path / "eps"),
        "--output",
        str(tmp_path / "ds"),
        "--repo_id",
        "me/lift_puck",
        "--sim_features",  # no camera: the policy observes the puck's pose
        cwd=tmp_path,
    )
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "WANDB_MODE": "disabled"}
    train = subprocess.run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_train",
            "--dataset.repo_id=me/lift_puck",
            f"--dataset.root={tmp_path / 'ds'}",
            "--policy.type=act",
            "--policy.device=cpu",
            "--policy.push_to_hub=false",
            "--policy.use_vae=false",
            "--policy.chunk_size=5",
            "--policy.n_action_steps=5",
            "--policy.dim_model=32",
            "--policy.dim_feedforward=64",
            "--policy.n_encoder_layers=1",
            "--policy.n_decoder_layers=1",
            "--steps=2",
            "--batch_size=2",
            "--num_workers=0",
            "--save_freq=2",
            "--wandb.enable=false",
            f"--output_dir={tmp_path / 'train'}",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env=env,
    )
    assert train.returncode == 0, train.stderr[-3000:]
    ckpt = tmp_path / "train" / "checkpoints" / "last" / "pretrained_model"
    evaluated = subprocess.run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_eval",
            f"--policy.path={ckpt}",
            "--env.type=trossen",
            "--env.task=lift_puck",
            "--env.cam_names=none",
            "--env.episode_length=10",
            "--env.controller_checks=false",
            "--eval.n_episodes=1",
            "--eval.batch_size=1",
            "--seed=3",
            f"--output_dir={tmp_path / 'ev'}",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env=env,
    )
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    info = json.loads((tmp_path / "ev" / "eval_info.json").read_text())
    (task,) = info["per_task"]
    metrics = task["metrics"]
    assert len(metrics["successes"]) == len(metrics["sum_rewards"]) == 1, info
    assert metrics["successes"] == [False]  # an untrained policy, 10 steps: the puck stays
    assert 0 <= metrics["max_rewards"][0] <= max(_lift_puck_stages().values())


def _lift_puck_stages() -> dict[str, float]:
    from trossen_arm_mujoco.tasks import registry

    return registry.stages("lift_puck")


def test_the_tutorial_shows_the_example_package_verbatim():
    """docs/writing-a-task.md's code blocks headed ``# my_trossen_task/<file>`` are excerpts
    of that file, character for character (the page is the example's code)."""
    page = (REPO / "docs" / "writing-a-task.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n# (my_trossen_task/\w+\.py)\n(.*?)\n```", page, re.S)
    assert {name for name, _ in blocks} == {"my_trossen_task/task.py", "my_trossen_task/policy.py"}
    for name, text in blocks:
        source = (TASK_PACKAGE / name).read_text(encoding="utf-8")
        assert text in source, f"the block of {name} differs from the file"
    shown = "".join(text for _, text in blocks)
    for name in ("class LiftPuckReward", "class LiftPuckSampler", "TASK = TaskEntry("):
        assert name in shown
    toml = re.search(r"```toml\n(.*?)\n```", page, re.S).group(1)
    assert toml == (TASK_PACKAGE / "pyproject.toml").read_text(encoding="utf-8").rstrip()
