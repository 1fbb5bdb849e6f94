"""A broken task config fails only the commands that use its task: importing the package,
registering the gym ids, listing tasks and ``--help`` read no YAML; using the broken task is
one ``error:`` line naming the file, the key and the reason (exit status 2)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import gymnasium as gym
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.registration import ENV_IDS, TaskEnvSpec, register_envs
from trossen_arm_mujoco.tasks import config as config_module
from trossen_arm_mujoco.tasks import registry

TRANSFER_ID = "TrossenMujoco/StationaryAITransferCube-v0"
REACH_ID = "TrossenMujoco/WXAIReach-v0"

#: ``python RUNNER <config dir> <trossen-mujoco args>``: the ``trossen-mujoco`` entry point with
#: ``tasks.config.CONFIG_DIR`` pointing at ``<config dir>`` from before the package's own
#: ``__init__`` (which registers the gym ids) runs.
RUNNER = """
import importlib.util, sys
from pathlib import Path
spec = importlib.util.find_spec("trossen_arm_mujoco")
package = importlib.util.module_from_spec(spec)
sys.modules["trossen_arm_mujoco"] = package
from trossen_arm_mujoco.tasks import config
config.CONFIG_DIR = Path(sys.argv[1])
spec.loader.exec_module(package)
from trossen_arm_mujoco.cli import main
sys.exit(main(sys.argv[2:]))
"""

#: (text in transfer_cube.yaml, its broken replacement, the key, the reason; {line}, {next}:
#: the replaced text's line and the one after it)
BREAKS = {
    "duplicate": (
        "max_episode_steps: 600",
        "max_episode_steps: 600\nmax_episode_steps: 60",
        "max_episode_steps",
        "given twice (lines {line} and {next}); keep one",
    ),
    "steps": (
        "max_episode_steps: 600",
        "max_episode_steps: 50.5",
        "max_episode_steps",
        "expected a whole number in [1, 10000000], got 50.5",
    ),
    "nan": (
        "safety_margin: 0.01",
        "safety_margin: .nan",
        "safety_margin",
        "expected a number in [0, 0.5] m, got nan",
    ),
    "unknown": (
        "ctrl_dt: 0.02",
        "ctrl_dt: 0.02\nctrl_hz: 50",
        "ctrl_hz",
        "unknown key (did you mean ctrl_dt?)",
    ),
}


def _broken_copy(tmp_path, kind: str = "duplicate"):
    """A copy of the config dir whose transfer_cube.yaml is broken; (dir, file, key, reason)."""
    copy = tmp_path / "config"
    shutil.copytree(config_module.CONFIG_DIR, copy)
    old, new, key, reason = BREAKS[kind]
    path = copy / "transfer_cube.yaml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    line = text[: text.index(old)].count("\n") + 1
    return copy, path, key, reason.format(line=line, next=line + 1)


@pytest.fixture
def broken(tmp_path, monkeypatch):
    """The loader reads a config dir whose transfer_cube.yaml holds a duplicate key."""
    copy, path, key, reason = _broken_copy(tmp_path)
    monkeypatch.setattr(config_module, "CONFIG_DIR", copy)
    return path, key, reason


def _cli(tmp_path, config_dir, *args: str) -> subprocess.CompletedProcess:
    runner = tmp_path / "runner.py"
    runner.write_text(RUNNER)
    return subprocess.run(
        [sys.executable, str(runner), str(config_dir), *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )


# --- the command line -----------------------------------------------------------------------
@pytest.mark.parametrize("args", [["--help"], ["record", "--help"]])
def test_help_works_with_a_broken_config(tmp_path, args):
    config_dir, *_ = _broken_copy(tmp_path)
    done = _cli(tmp_path, config_dir, *args)
    assert done.returncode == 0, done.stderr
    assert "usage:" in done.stdout and done.stderr == ""


@pytest.mark.parametrize("kind", sorted(BREAKS))
def test_using_the_broken_task_is_one_error_line_with_file_key_reason(tmp_path, kind):
    config_dir, path, key, reason = _broken_copy(tmp_path, kind)
    done = _cli(
        tmp_path,
        config_dir,
        "record",
        "--task_name",
        "sim_transfer_cube",
        "--num_episodes",
        "1",
        "--cam_names",
        "none",
        "--root_dir",
        str(tmp_path),
        "--data_dir",
        "transfer",
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"error: config file {path}, key {key}: {reason}")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr


def test_another_task_still_records(tmp_path):
    config_dir, *_ = _broken_copy(tmp_path)
    done = _cli(
        tmp_path,
        config_dir,
        "record",
        "--task_name",
        "sim_insertion",
        "--num_episodes",
        "1",
        "--episode_len",
        "3",
        "--cam_names",
        "none",
        "--root_dir",
        str(tmp_path),
        "--data_dir",
        "insertion",
    )
    # a 3-step episode is recorded (and fails the task: exit status 1 at most), no error line
    assert done.returncode in (0, 1) and "error:" not in done.stderr, done.stderr
    assert "recorded 1 episode(s)" in done.stdout


# --- in process -------------------------------------------------------------------------------
def test_registration_and_listings_read_no_config(monkeypatch, broken):
    def no_reading(path):
        raise AssertionError(f"{path} was read")

    monkeypatch.setattr(config_module, "read_yaml", no_reading)
    for env_id in ENV_IDS:
        monkeypatch.delitem(gym.registry, env_id)
    assert register_envs() == list(ENV_IDS)
    assert all(isinstance(gym.spec(env_id), TaskEnvSpec) for env_id in ENV_IDS)
    assert "TrossenMujoco/WXAIReach-v0" in gym.pprint_registry(disable_print=True)
    assert "sim_transfer_cube" in registry.names()
    assert {"sim_insertion", "sim_transfer_cube"} <= set(registry.scripted_names())
    assert registry.sim_task_configs()["sim_transfer_cube"]["episode_len"] == 600
    from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS

    assert "sim_transfer_cube" in SIM_TASK_CONFIGS
    assert len(SIM_TASK_CONFIGS) == len(registry.scripted_names())
    assert sorted(SIM_TASK_CONFIGS) == registry.scripted_names()  # installed packages' too
    assert SIM_TASK_CONFIGS.get("sim_transfer_cube")["episode_len"] == 600


def test_gym_ids_of_a_broken_task_fail_when_made(monkeypatch, broken):
    path, key, reason = broken
    for env_id in ENV_IDS:
        monkeypatch.delitem(gym.registry, env_id)
    register_envs()
    with pytest.raises(UserError) as err:
        gym.make(TRANSFER_ID)
    assert str(err.value) == f"config file {path}, key {key}: {reason}"
    with pytest.raises(UserError, match="transfer_cube.yaml, key max_episode_steps"):
        _ = gym.spec(TRANSFER_ID).max_episode_steps
    assert gym.spec(REACH_ID).max_episode_steps == 50  # read from reach.yaml now
    env = gym.make(REACH_ID)
    try:
        assert env.spec.max_episode_steps == 50
        env.reset(seed=0)
    finally:
        env.close()


def test_sim_task_configs_lookup_checks_the_task_config(broken):
    from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS

    path, key, reason = broken
    with pytest.raises(UserError) as err:
        SIM_TASK_CONFIGS["sim_transfer_cube"]
    assert str(err.value) == f"config file {path}, key {key}: {reason}"
    assert SIM_TASK_CONFIGS["sim_insertion"]["episode_len"] == 400
    with pytest.raises(KeyError):
        SIM_TASK_CONFIGS["reach"]  # no scripted policy


def test_make_sampler_of_the_broken_task_names_file_and_key(broken):
    path, key, _ = broken
    with pytest.raises(UserError, match=f"config file {path}, key {key}: "):
        registry.make_sampler("sim_transfer_cube")


def test_task_env_spec_value_can_be_set_and_copied():
    import copy
    import pickle

    spec = TaskEnvSpec(id="TrossenMujoco/Probe-v0", entry_point="x:y", task="reach")
    assert spec.max_episode_steps == 50
    clone = copy.deepcopy(spec)
    clone.max_episode_steps = 7
    assert clone.max_episode_steps == 7 and spec.max_episode_steps == 50
    assert pickle.loads(pickle.dumps(spec)).max_episode_steps == 50
    fixed = TaskEnvSpec(id="TrossenMujoco/Probe-v0", entry_point="x:y", max_episode_steps=3)
    assert fixed.max_episode_steps == 3
