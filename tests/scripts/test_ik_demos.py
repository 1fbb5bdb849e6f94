"""The vendor's four IK demo scripts run headless (``--headless``, or without a display) and
succeed: the cube placed within the script's stated distance of the target, or the target
tracked within the stated error bound."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPTS = REPO / "trossen_arm_mujoco" / "scripts"


def _run(name: str, *args: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "egl"
    return subprocess.run(
        [sys.executable, str(SCRIPTS / name), *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize(
    ("name", "sentence"),
    [
        ("wxai_pick_place.py", r"picked the cube and placed it (\d\.\d+) m from the target"),
        ("stationary_ai_pick_place.py", r"the right arm placed it (\d\.\d+) m from the target"),
        ("mobile_ai_pick_place.py", r"the right arm placed it (\d\.\d+) m from the target"),
    ],
)
def test_pick_place_places_the_cube(name, sentence):
    proc = _run(name, "--headless")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    found = re.search(sentence, proc.stdout)
    assert found, proc.stdout
    assert float(found.group(1)) <= 0.02  # SUCCESS_DISTANCE of the scripts
    if name.startswith("mobile"):
        drove = re.search(r"drove (\d\.\d+) m to the table", proc.stdout)
        assert drove and abs(float(drove.group(1)) - 0.3) < 0.01, proc.stdout
    assert proc.stderr == ""


def test_follow_target_tracks_within_the_bound():
    proc = _run("wxai_follow_target.py", "--headless")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    found = re.search(r"mean (\d\.\d+) m, max (\d\.\d+) m \(below the bound 0.01 m\)", proc.stdout)
    assert found, proc.stdout
    assert float(found.group(2)) < 0.01


def test_no_display_runs_headless_and_says_so():
    proc = _run("wxai_follow_target.py")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (
        proc.stderr.strip()
        == "note: no display found: running headless (pass --headless to say so)"
    )
    assert "tracked the target" in proc.stdout


def test_bad_flag_is_one_line():
    proc = _run("wxai_pick_place.py", "--fast")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "error: unrecognized arguments: --fast (see 'wxai_pick_place.py --help')"
    ]
