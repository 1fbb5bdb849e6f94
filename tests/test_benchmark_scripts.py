"""The step-overhead benchmark runs end to end (tiny run; figures are printed, never asserted)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "step_overhead.py"


def test_step_overhead_measures_each_env_in_its_own_process():
    env = {**os.environ, "MUJOCO_GL": "egl"}
    args = ["--steps", "20", "--dm-steps", "20", "--repeats", "1", "--only", "TransferCubeTask"]
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| dm_control")]
    assert len(rows) == 1 and "TransferCubeTask (joint)" in rows[0]
    ratio = float(rows[0].split("|")[-2])
    assert ratio > 0  # a figure was measured; its size is the benchmark's to report


def test_eval_throughput_prints_the_ratio_and_the_scaling():
    script = SCRIPT.parent / "eval_throughput.py"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    args = ["--steps", "4", "--repeats", "1", "--image_size", "24x32", "--workers", "1,2"]
    done = subprocess.run(
        [sys.executable, str(script), *args], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    ratio = next(line for line in lines if line.strip().startswith("ratio env/raw"))
    assert float(ratio.split()[-1]) > 0
    assert any("last images identical: yes" in line for line in lines), done.stdout
    rows = [line.split() for line in lines if line.split()[:1] in (["1"], ["2"])]
    assert [r[0] for r in rows] == ["1", "2"] and all(float(r[1]) > 0 for r in rows)


def test_numpy_paths_compares_the_variants_and_checks_the_draws():
    script = SCRIPT.parent / "numpy_paths.py"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    args = ["--n", "20", "--repeats", "1", "--draws", "50"]
    done = subprocess.run(
        [sys.executable, str(script), *args], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| two floats")]
    assert rows and all(line.rstrip(" |").endswith("yes") for line in rows)  # same draws
    assert "umath.clip" in done.stdout and "| 58 " in done.stdout
