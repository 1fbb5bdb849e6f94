"""Local worker processes: results with positions, errors, workers that die every time.

The tasks are builtins (picklable in a spawned process); a worker killed mid-attempt while
recording is tested with the recorder in ``test_parallel.py``."""

from __future__ import annotations

import math
import os

import pytest

from trossen_arm_mujoco.collect.local_pool import (
    RemoteTraceback,
    WorkerPool,
    describe_exit,
)
from trossen_arm_mujoco.errors import UserError


def _pool(task, workers=2, **kwargs) -> WorkerPool:
    return WorkerPool(workers, os.getpid, (), task, **kwargs)


def test_every_result_comes_back_with_its_position():
    pool = _pool(abs)
    try:
        results = dict(pool.results([-3, 4, -5, 6, -7]))
    finally:
        assert pool.shutdown() == []
    assert results == {0: 3, 1: 4, 2: 5, 3: 6, 4: 7}


def test_an_error_in_a_job_is_raised_with_the_worker_traceback():
    pool = _pool(math.sqrt, workers=1)
    try:
        with pytest.raises(ValueError, match="math domain error") as exc_info:
            list(pool.results([4.0, -1.0]))
    finally:
        pool.shutdown()
    assert isinstance(exc_info.value.__cause__, RemoteTraceback)
    assert "in the worker process" in str(exc_info.value.__cause__)


def test_a_job_whose_worker_dies_every_time_ends_in_one_line():
    warnings: list[str] = []
    pool = _pool(os._exit, workers=1, warn=warnings.append, describe=lambda code: f"job {code}")
    try:
        with pytest.raises(UserError) as exc_info:
            list(pool.results([7]))
    finally:
        pool.shutdown()
    assert str(exc_info.value) == (
        "job 7: the worker process running it died in each of 3 tries (last: exit status 7); "
        "check memory use and rerun the same command to continue"
    )
    assert len(warnings) == 2
    assert warnings[0].endswith("died (exit status 7); running job 7 again (try 2 of 3)")


def test_describe_exit():
    assert describe_exit(-9) == "killed by SIGKILL, out of memory?"
    assert describe_exit(-15) == "killed by SIGTERM"
    assert describe_exit(3) == "exit status 3"


def test_a_warning_in_a_worker_prints_as_one_note_line(capfd):
    import warnings

    pool = _pool(warnings.warn, workers=1)
    try:
        assert dict(pool.results(["the light is low"])) == {0: None}
    finally:
        assert pool.shutdown() == []
    err = capfd.readouterr().err
    assert "note: the light is low" in err
    assert "UserWarning" not in err and "warnings.warn" not in err
