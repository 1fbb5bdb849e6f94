"""What a record run says: the plan of a continued dataset, warnings, the outcome's lines and
exit status (reports built by hand; no episode recorded here)."""

from __future__ import annotations

import argparse
import errno

import pytest

from trossen_arm_mujoco.collect.parallel import RunReport
from trossen_arm_mujoco.collect.pipeline import RecordSettings
from trossen_arm_mujoco.collect.resume import RunPlan
from trossen_arm_mujoco.data.io_errors import EpisodeIOError
from trossen_arm_mujoco.errors import EXIT_INTERRUPTED, EXIT_TERMINATED
from trossen_arm_mujoco.scripts.record_report import (
    report_run,
    say_plan,
    warn_disk_space,
    warn_short_episodes,
)

ARGS = argparse.Namespace(task_name="sim_transfer_cube", skip_failed=False)


def _report(tmp_path, report: RunReport, plan: RunPlan | None = None) -> int:
    plan = plan or RunPlan(indices=[0, 1], attempts=[0, 1], first_attempt=0)
    return report_run(ARGS, report, 16, plan, tmp_path, 2, 1.0, 440, 440)


def test_say_plan_names_what_is_kept_missing_and_recorded_again(tmp_path, capsys):
    say_plan(RunPlan(indices=[0, 1], attempts=[0, 1], first_attempt=0), tmp_path, 2)
    assert capsys.readouterr().out == ""  # a fresh dataset: nothing to say
    plan = RunPlan(indices=[1, 3], attempts=[5, 6], first_attempt=5, existing=[0, 2], failed=[3])
    say_plan(plan, tmp_path, 4)
    assert capsys.readouterr().out.strip() == (
        f"continuing the dataset in {tmp_path}: keeping episodes 0, 2; missing: episode 1; "
        "failed before, recording again: episode 3"
    )


def test_warnings(tmp_path, capsys):
    warn_short_episodes("sim_transfer_cube", 440, 440)
    assert capsys.readouterr().err == ""
    warn_short_episodes("sim_transfer_cube", 20, 440)
    assert "--episode_len 20 is shorter than the 440 steps" in capsys.readouterr().err
    huge = RecordSettings(episode_len=10**9, compression="none")
    warn_disk_space(tmp_path, huge, 1)
    assert "free disk space, record fewer episodes" in capsys.readouterr().err
    warn_disk_space(tmp_path, RecordSettings(episode_len=10**9), 1)  # gzip: size unknown
    assert capsys.readouterr().err == ""


def test_an_io_error_is_one_error_line(tmp_path, capsys):
    full = EpisodeIOError("cannot write episode_1.hdf5: no space left", errno.ENOSPC)
    assert _report(tmp_path, RunReport(io_error=full)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "error: cannot write episode_1.hdf5: no space left; complete episodes: none; free "
        "disk space or choose another --root_dir, then rerun to continue"
    ]


@pytest.mark.parametrize(
    ("terminated", "status"), [(False, EXIT_INTERRUPTED), (True, EXIT_TERMINATED)]
)
def test_an_interrupt_says_what_was_kept(tmp_path, capsys, terminated, status):
    report = RunReport(interrupted=True, terminated=terminated)
    assert _report(tmp_path, report) == status
    err = capsys.readouterr().err
    assert ("SIGTERM" if terminated else "Ctrl-C") in err and "rerun the same command" in err


def test_nothing_failed_is_exit_0(tmp_path, capsys):
    assert _report(tmp_path, RunReport()) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1] == "Success: 0 / 0"
