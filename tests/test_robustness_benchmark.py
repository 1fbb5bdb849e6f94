"""benchmarks/robustness.py: its conditions are valid randomization files, each turning on
only what its label says, and a tiny run of the scripted policy writes its table."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.config_key import Source
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_KEY, check_randomization

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "robustness.py"


def _module():
    spec = importlib.util.spec_from_file_location("robustness_benchmark", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_each_condition_turns_on_only_its_kinds():
    bench = _module()
    base = registry.load("sim_transfer_cube").load_config()[RANDOMIZATION_KEY]
    rows = bench.conditions(None)
    labels = [label for label, _, _ in rows]
    assert labels[:3] == ["nominal", "train", "hard"]
    assert {"lights", "table", "cube colour", "camera pose", "physics"} <= set(labels)
    for label, flags, section in rows:
        if section is None:
            assert flags == ["--randomize", label]
            continue
        checked = check_randomization(Source("test"), base, section["randomization"])
        on = {kind for kind, params in checked.items() if params["enabled"]}
        if label.startswith("camera ") and label != "camera pose":
            assert on == {"camera"}
            cam = checked["camera"]
            moved, turned = cam["position"] > 0, cam["orientation_deg"] > 0
            assert moved != turned  # one of the two, set by the label
            amount = float(label.split()[1].lstrip("+-"))
            assert (cam["position"] * 1000 if moved else cam["orientation_deg"]) == amount
        else:
            assert on == set(bench.ALONE[label])
            assert all(checked[kind] == {**base[kind], "enabled": True} for kind in on)


def test_a_tiny_run_writes_its_rows(tmp_path):
    env = {**os.environ, "MUJOCO_GL": "egl"}
    cmd = [sys.executable, str(SCRIPT), "--policy", "scripted", "--episodes", "1"]
    cmd += ["--workers", "1", "--out", str(tmp_path), "--only", "camera 4 deg"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "| camera 4 deg | 100.0 % |" in proc.stdout
    report = json.loads((tmp_path / "robustness.json").read_text())
    assert [row["condition"] for row in report["rows"]] == ["camera 4 deg"]
    # rerun: read, not run again
    again = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert again.returncode == 0 and "| camera 4 deg | 100.0 % |" in again.stdout


def test_an_unknown_condition_is_one_line(tmp_path):
    cmd = [sys.executable, str(SCRIPT), "--policy", "scripted", "--out", str(tmp_path)]
    proc = subprocess.run(cmd + ["--only", "fog"], capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    assert proc.stderr.startswith("error: unknown condition(s) ['fog']; valid: nominal")
    assert len(proc.stderr.strip().splitlines()) == 1
