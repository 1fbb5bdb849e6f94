"""Replay outputs: CSV of commanded vs measured, JSON summary, plot, atomic writes."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.real.report import LABELS, TrackingLog, format_error_table, write_outputs


def make_log(num_steps: int = 5) -> TrackingLog:
    log = TrackingLog()
    for k in range(num_steps):
        cmd = np.full((2, 7), 0.1 * k)
        meas = cmd.copy()
        meas[0, 1] -= 0.02  # left joint_1 lags 20 mrad
        meas[1, 6] += 0.001 * (k % 2)  # right gripper off by 1 mm every other step
        log.add(0.1 * (k + 1), cmd, meas)
    return log


def test_errors_per_joint() -> None:
    err = make_log().errors()
    assert list(err) == list(LABELS) and len(LABELS) == 14
    assert err["left_joint_1"]["rms"] == pytest.approx(0.02)
    assert (
        err["left_joint_1"]["max"] == pytest.approx(0.02) and err["left_joint_1"]["unit"] == "rad"
    )
    assert (
        err["right_gripper"]["max"] == pytest.approx(0.001) and err["right_gripper"]["unit"] == "m"
    )
    assert err["right_gripper"]["rms"] == pytest.approx(0.001 * np.sqrt(2 / 5))
    assert err["left_joint_0"]["rms"] == 0.0
    assert TrackingLog().errors()["left_joint_0"]["rms"] is None


def test_error_table_in_mrad_and_mm() -> None:
    table = format_error_table(make_log().errors())
    lines = table.splitlines()
    assert len(lines) == 8 and "left rms" in lines[0]
    assert lines[2].split()[:4] == ["joint_1", "mrad", "20.00", "20.00"]
    assert lines[7].split()[:2] == ["gripper", "mm"] and lines[7].split()[-1] == "1.00"


def test_write_outputs(tmp_path: Path) -> None:
    paths = write_outputs(tmp_path / "replay", "episode_0_sim", make_log(), {"status": "x"})
    assert paths["csv"].name == "episode_0_sim_tracking.csv"
    with paths["csv"].open() as f:
        rows = list(csv.reader(f))
    assert rows[0][:4] == ["step", "time_s", "cmd_left_joint_0", "meas_left_joint_0"]
    assert len(rows[0]) == 2 + 28 and len(rows) == 1 + 5
    assert float(rows[1][rows[0].index("meas_left_joint_1")]) == pytest.approx(-0.02)
    summary = json.loads(paths["summary"].read_text())
    assert summary["status"] == "x"
    assert summary["tracking_error"]["left_joint_1"]["rms"] == pytest.approx(0.02)
    assert paths["plot"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in (tmp_path / "replay").iterdir()) == sorted(
        p.name for p in paths.values()
    )  # no temporary files left


def test_without_matplotlib_the_plot_is_skipped_with_a_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib.backends.backend_agg", None)
    paths = write_outputs(tmp_path, "e", make_log(), {})
    assert paths["plot"] is None and not (tmp_path / "e_tracking.png").exists()
    summary = json.loads(paths["summary"].read_text())
    assert "pip install 'trossen-arm-mujoco[video]'" in summary["plot"]


def test_empty_log_writes_header_and_valid_json(tmp_path: Path) -> None:
    paths = write_outputs(tmp_path, "e", TrackingLog(), {"steps_done": 0})
    assert len(paths["csv"].read_text().splitlines()) == 1
    assert json.loads(paths["summary"].read_text())["tracking_error"]["left_joint_0"]["max"] is None
    assert paths["plot"] is None


def test_failed_write_leaves_no_partial_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from trossen_arm_mujoco.fileio import atomic_path
    from trossen_arm_mujoco.real import report

    def broken(path: Path, text: str, **_) -> None:  # the disk fills up mid-write
        with atomic_path(path) as tmp:
            tmp.write_text("partial")
            raise OSError("disk full")

    monkeypatch.setattr(report, "write_text", broken)
    with pytest.raises(OSError, match="disk full"):
        write_outputs(tmp_path, "e", make_log(), {})
    assert list(tmp_path.iterdir()) == []
