"""The evaluation runner: scripted reference, determinism across runs and workers,
module:function policies, videos."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
import uuid
from pathlib import Path

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.runner import VIDEO_DIR, EvalSettings, evaluate

# The scripted transfer needs its full 600 steps to succeed; without cameras an episode
# takes about 1.5 s.
SCRIPTED = EvalSettings(policy="scripted", task="sim_transfer_cube", num_episodes=2, seed=5)

HOLD_MODULE = """
import numpy as np

from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE

POSE = KIT14_LAYOUT.from_vendor(np.asarray(START_ARM_POSE))
RESETS = []


def hold(observation):
    assert observation["agent_pos"].shape == (14,)
    return POSE.copy()


hold.reset = lambda: RESETS.append(1)
"""


@pytest.fixture(scope="module")
def scripted_info(tmp_path_factory):
    out = tmp_path_factory.mktemp("scripted")
    return evaluate(EvalSettings(**{**SCRIPTED.__dict__, "output_dir": str(out)}))


def _rows(info: dict) -> list[dict]:
    return info["per_episode"]


def test_scripted_policy_succeeds(scripted_info):
    rows = _rows(scripted_info)
    assert [r["episode_ix"] for r in rows] == [0, 1]
    assert [r["seed"] for r in rows] == [5, 6]  # episode i is seed S + i
    for r in rows:
        assert r["success"] and r["max_reward"] == 4.0 and r["steps"] == 600
        assert r["stages"] == {"touched": True, "lifted": True, "transferred": True}
    agg = scripted_info["aggregated"]
    assert agg["pc_success"] == 100.0 and agg["n_episodes"] == 2
    assert agg["pc_success_ci95"][1] == 100.0
    assert agg["stages"] == {"touched": 100.0, "lifted": 100.0, "transferred": 100.0}
    assert scripted_info["video_paths"] == []
    assert scripted_info["run"]["policy"] == "scripted"
    assert scripted_info["run"]["num_workers"] == 1 and scripted_info["run"]["engine"] == "local"


def test_same_settings_give_the_same_episodes(scripted_info, tmp_path):
    again = evaluate(EvalSettings(**{**SCRIPTED.__dict__, "output_dir": str(tmp_path)}))
    assert _rows(again) == _rows(scripted_info)


def test_two_workers_give_the_same_episodes_as_one(scripted_info, tmp_path):
    two = evaluate(EvalSettings(**{**SCRIPTED.__dict__, "output_dir": str(tmp_path)}), 2)
    assert _rows(two) == _rows(scripted_info)
    assert two["run"]["num_workers"] == 2


@pytest.fixture
def hold_policy(tmp_path, monkeypatch):
    """A ``module:function`` policy holding the start pose, importable for the test (and
    for spawned workers through PYTHONPATH); yields (spec, module name)."""
    name = f"hold_start_{uuid.uuid4().hex[:8]}"
    folder = tmp_path / "policies"
    folder.mkdir()
    (folder / f"{name}.py").write_text(textwrap.dedent(HOLD_MODULE), encoding="utf-8")
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("PYTHONPATH", str(folder))
    return f"{name}:hold", name


def test_function_policy_holding_the_start_pose_scores_nothing(hold_policy, tmp_path):
    spec, name = hold_policy
    settings = EvalSettings(
        policy=spec, num_episodes=2, episode_length=40, output_dir=str(tmp_path / "out")
    )
    info = evaluate(settings)
    rows = _rows(info)
    assert [r["steps"] for r in rows] == [40, 40]
    assert all(not r["success"] and r["max_reward"] == 0.0 for r in rows)
    assert all(not any(r["stages"].values()) for r in rows)
    assert info["aggregated"]["pc_success"] == 0.0
    assert info["aggregated"]["pc_success_ci95"][0] == 0.0
    assert len(sys.modules[name].RESETS) == 2  # its reset() ran at every episode start


def test_a_user_error_in_a_worker_is_one_user_error(tmp_path):
    """A policy that cannot be built in a worker process is the user's error, not a dead
    worker (and not a traceback)."""
    settings = EvalSettings(
        policy="no_such_module_for_eval:act",
        num_episodes=2,
        episode_length=2,
        output_dir=str(tmp_path),
    )
    for workers in (1, 2):
        with pytest.raises(UserError, match="cannot import it"):
            evaluate(settings, workers)


def test_unknown_engine_lists_the_valid_ones(tmp_path):
    with pytest.raises(UserError, match="valid engines: local, ray"):
        evaluate(EvalSettings(output_dir=str(tmp_path)), engine="dask")


@pytest.mark.skipif(importlib.util.find_spec("av") is None, reason="needs PyAV")
def test_videos_writes_the_first_rollouts(hold_policy, tmp_path):
    from trossen_arm_mujoco.data.video import video_info

    spec, _ = hold_policy
    out = tmp_path / "out"
    settings = EvalSettings(
        policy=spec, num_episodes=2, episode_length=10, videos=1, output_dir=str(out)
    )
    info = evaluate(settings)
    path = out / VIDEO_DIR / "eval_episode_0.mp4"
    assert info["video_paths"] == [str(path)] == info["overall"]["video_paths"]
    assert sorted(p.name for p in (out / VIDEO_DIR).iterdir()) == ["eval_episode_0.mp4"]
    meta = video_info(Path(path))
    # no camera observed: cam_high at 240x320; the first frame is the reset's
    assert (meta["height"], meta["width"], meta["frames"]) == (240, 320, 11)


def test_ray_engine_gives_the_same_episodes_as_local(scripted_info, tmp_path):
    """``eval --engine ray`` in its own process (a Ray started again in a process that already
    ran one, as earlier test modules do, can hang in its GCS start)."""
    pytest.importorskip("ray")
    out = tmp_path / "ray"
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--policy",
            "scripted",
            "--task_name",
            SCRIPTED.task,
            "--num_episodes",
            str(SCRIPTED.num_episodes),
            "--seed",
            str(SCRIPTED.seed),
            "--num_workers",
            "2",
            "--engine",
            "ray",
            "--output_dir",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    on_ray = json.loads((out / "eval_info.json").read_text())
    assert _rows(on_ray) == _rows(scripted_info)
    assert on_ray["run"]["engine"] == "ray" and on_ray["aggregated"]["pc_success"] == 100.0


THREADS_MODULE = """
import os
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE

POSE = KIT14_LAYOUT.from_vendor(np.asarray(START_ARM_POSE))


def act(observation):
    import torch

    seen = f"{os.getpid()} {os.environ.get('OMP_NUM_THREADS')} {torch.get_num_threads()}"
    with open(Path(os.environ["THREADS_LOG"]) / f"{os.getpid()}.txt", "w") as f:
        f.write(seen)
    return POSE.copy()
"""


def test_threads_per_worker_shares_the_cores():
    from trossen_arm_mujoco.eval.runner import threads_per_worker
    from trossen_arm_mujoco.processes import available_cpus

    assert threads_per_worker(1, 16) == 16
    assert threads_per_worker(2, 16) == 8
    assert threads_per_worker(3, 16) == 5
    assert threads_per_worker(2, 2) == 1
    assert threads_per_worker(1000, 2) == 1
    assert threads_per_worker(1) == available_cpus() >= 1


def test_thread_env_is_restored(monkeypatch):
    from trossen_arm_mujoco.eval.runner import THREAD_VARS, thread_env

    monkeypatch.setenv("OMP_NUM_THREADS", "7")
    monkeypatch.delenv("MKL_NUM_THREADS", raising=False)
    with thread_env(3):
        assert all(os.environ[k] == "3" for k in THREAD_VARS)
    assert os.environ["OMP_NUM_THREADS"] == "7" and "MKL_NUM_THREADS" not in os.environ


def test_each_worker_gets_its_share_of_the_cores(tmp_path, monkeypatch):
    """Two workers: each worker's OpenMP variable and torch use max(1, C // 2) threads (not
    torch's default of every core)."""
    pytest.importorskip("torch")
    from trossen_arm_mujoco.processes import available_cpus

    name = f"threads_{uuid.uuid4().hex[:8]}"
    folder, log = tmp_path / "policies", tmp_path / "log"
    folder.mkdir()
    log.mkdir()
    (folder / f"{name}.py").write_text(textwrap.dedent(THREADS_MODULE), encoding="utf-8")
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("PYTHONPATH", str(folder))
    monkeypatch.setenv("THREADS_LOG", str(log))
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    settings = EvalSettings(
        policy=f"{name}:act", num_episodes=2, episode_length=1, output_dir=str(tmp_path / "out")
    )
    evaluate(settings, 2)
    want = str(max(1, available_cpus() // 2))
    seen = [p.read_text().split() for p in log.iterdir()]
    assert seen and all(s[1:] == [want, want] for s in seen), seen
    assert "OMP_NUM_THREADS" not in os.environ  # the parent's environment is restored
