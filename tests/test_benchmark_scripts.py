"""The step-overhead benchmark runs end to end (tiny run; figures are printed, never asserted)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "step_overhead.py"


def run_benchmark(name: str, args: list[str], timeout: float = 300):
    """``python benchmarks/NAME ARGS`` with software EGL; the finished process."""
    env = {**os.environ, "MUJOCO_GL": "egl"}
    return subprocess.run(
        [sys.executable, str(SCRIPT.parent / name), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
    )


def test_step_overhead_measures_each_env_in_its_own_process():
    args = ["--steps", "20", "--dm-steps", "20", "--repeats", "1", "--only", "TransferCubeTask"]
    done = run_benchmark(SCRIPT.name, args)
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| dm_control")]
    assert len(rows) == 1 and "TransferCubeTask (joint)" in rows[0]
    ratio = float(rows[0].split("|")[-2])
    assert ratio > 0  # a figure was measured; its size is the benchmark's to report


def test_eval_throughput_prints_the_ratio_and_the_scaling():
    args = ["--steps", "4", "--repeats", "1", "--image_size", "24x32", "--workers", "1,2"]
    done = run_benchmark("eval_throughput.py", args)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    ratio = next(line for line in lines if line.strip().startswith("ratio env/raw"))
    assert float(ratio.split()[-1]) > 0
    assert any("last images identical: yes" in line for line in lines), done.stdout
    rows = [line.split() for line in lines if line.split()[:1] in (["1"], ["2"])]
    assert [r[0] for r in rows] == ["1", "2"] and all(float(r[1]) > 0 for r in rows)


def test_numpy_paths_compares_the_variants_and_checks_the_draws():
    args = ["--n", "20", "--repeats", "1", "--draws", "50"]
    done = run_benchmark("numpy_paths.py", args)
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| two floats")]
    assert rows and all(line.rstrip(" |").endswith("yes") for line in rows)  # same draws
    assert "umath.clip" in done.stdout and "| 58 " in done.stdout


@pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest
def test_train_step_profile_splits_an_act_step_into_its_parts(tmp_path):
    """Needs LeRobot (``TROSSEN_LEROBOT_PYTHON``, set by ``.ci/run``); a tiny model and data."""
    lerobot_python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not lerobot_python or not Path(lerobot_python).is_file():
        pytest.skip("TROSSEN_LEROBOT_PYTHON is not set to a Python with LeRobot (.ci/run sets it)")
    env = {**os.environ, "MUJOCO_GL": "egl"}
    cli = [sys.executable, "-m", "trossen_arm_mujoco.cli"]
    data, dataset = tmp_path / "episodes", tmp_path / "dataset"
    for args in (
        [
            "record",
            "--data_dir",
            str(data),
            "--num_episodes",
            "1",
            "--episode_len",
            "440",
            "--cam_names",
            "none",
            "--seed",
            "0",
        ],
        [
            "export",
            "--data_dir",
            str(data),
            "--output",
            str(dataset),
            "--repo_id",
            "local/tiny",
            "--sim_features",  # no camera: ACT observes the cube's pose
        ],
    ):
        done = subprocess.run([*cli, *args], capture_output=True, text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr
    script = SCRIPT.parent / "train_step_profile.py"
    args = [
        "--steps",
        "2",
        "--warmup",
        "1",
        "--batch_size",
        "4",
        "--dim_model",
        "32",
        "--dim_feedforward",
        "64",
        "--n_encoder_layers",
        "1",
        "--chunk_size",
        "5",
        "--threads",
        "1",
        "--json",
        str(tmp_path / "profile.json"),
    ]
    done = subprocess.run(
        [lerobot_python, str(script), str(dataset), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    rows = [line.split("|") for line in done.stdout.splitlines() if line.startswith("| ")]
    parts = [r[1].strip() for r in rows[1:]]
    assert parts == ["data", "preprocess", "forward", "backward", "optimizer", "step"], rows
    assert float(rows[-1][2]) > 0 and rows[-1][4].strip() == "100.0%"
    result = json.loads((tmp_path / "profile.json").read_text())
    assert all(len(result["times_s"][p]) == 2 for p in parts[:-1])


def test_render_profile_splits_a_frame_and_compares_each_row_with_before():
    args = ["--sizes", "12x16", "--cams", "1", "--frames", "2", "--rows", "now,now --no_shadows"]
    done = run_benchmark("render_profile.py", args)
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines() if line.split()[:1] == ["12x16"]]
    assert [r[2] for r in rows] == ["before", "now", "now"]
    assert rows[0][-1] == "same" and all(float(r[-2]) > 0 for r in rows)
    bad = run_benchmark("render_profile.py", ["--rows", "pretty"], timeout=60)
    assert bad.returncode != 0 and "unknown row 'pretty'" in bad.stderr
