"""``examples/``: each runs to completion where its requirements are installed, and otherwise
says in one line what is missing (exit 2). Loopback addresses 127.0.0.101 .. 127.0.0.109."""

from __future__ import annotations

import importlib.util
import json
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
        capture_output=True, text=True, timeout=300, cwd=REPO,
    )  # fmt: skip


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
        capture_output=True, text=True, timeout=300, cwd=cwd,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


@pytest.mark.once
def test_the_example_task_package_records_exports_and_evaluates(tmp_path):
    _require_task_package()
    out = _cli("record", "--task_name", "lift_puck", "--data_dir", str(tmp_path / "eps"),
               "--num_episodes", "2", "--cam_names", "none", cwd=tmp_path)  # fmt: skip
    assert "Success: 2 / 2" in out, out
    out = _cli("export", "--data_dir", str(tmp_path / "eps"), "--output", str(tmp_path / "ds"),
               "--repo_id", "me/lift_puck", cwd=tmp_path)  # fmt: skip
    assert "exported 2 episode(s)" in out, out
    info = json.loads((tmp_path / "ds" / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2
    _cli("eval", "--policy", "scripted", "--task_name", "lift_puck", "--num_episodes", "2",
         "--cam_names", "none", "--output_dir", str(tmp_path / "ev"), cwd=tmp_path)  # fmt: skip
    agg = json.loads((tmp_path / "ev" / "eval_info.json").read_text())["aggregated"]
    assert agg["pc_success"] == 100.0 and agg["stages"] == {"touched": 100.0, "lifted": 100.0}


@pytest.mark.once
def test_the_example_task_packages_own_tests_pass():
    _require_task_package()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"],
        capture_output=True, text=True, timeout=300, cwd=TASK_PACKAGE,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr


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
