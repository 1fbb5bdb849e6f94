"""``examples/``: each runs to completion where its requirements are installed, and otherwise
says in one line what is missing (exit 2). Loopback addresses 127.0.0.101 .. 127.0.0.109."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

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
