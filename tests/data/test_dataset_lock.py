"""One writer per dataset folder: a real flock held by another process."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from trossen_arm_mujoco.data.dataset_lock import (
    LOCK_FILE,
    DatasetLock,
    DatasetLockedError,
    is_locked_here,
    read_holder,
)
from trossen_arm_mujoco.errors import UserError

REPO = Path(__file__).resolve().parents[2]

#: Another process: takes the lock, says so, holds it until stdin closes (or a delay passes).
HOLDER = """
import sys, time
from trossen_arm_mujoco.data.dataset_lock import DatasetLock
with DatasetLock(sys.argv[1]):
    print("held", flush=True)
    if sys.argv[2] == "stdin":
        sys.stdin.read()
    else:
        time.sleep(float(sys.argv[2]))
"""


def _holder(folder: Path, until: str = "stdin") -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(folder), until],
        cwd=REPO,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_lock_file_holds_the_pid_and_goes_away(tmp_path):
    with DatasetLock(tmp_path) as lock:
        assert lock.held and is_locked_here(tmp_path)
        assert read_holder(tmp_path)[0] == os.getpid()
    assert not lock.held and not is_locked_here(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_reentrant_in_one_process(tmp_path):
    with DatasetLock(tmp_path), DatasetLock(tmp_path):
        assert (tmp_path / LOCK_FILE).exists()
    assert not (tmp_path / LOCK_FILE).exists()


def test_another_process_holding_the_folder_is_refused_with_its_pid(tmp_path):
    proc = _holder(tmp_path)
    try:
        with pytest.raises(DatasetLockedError) as exc_info:
            DatasetLock(tmp_path).acquire()
        assert exc_info.value.pid == proc.pid
        assert str(exc_info.value) == (
            f"another record run (pid {proc.pid}) is writing to {tmp_path}; wait for it to "
            "finish (or pass --wait), or choose another --data_dir"
        )
    finally:
        proc.communicate("")
    with DatasetLock(tmp_path):  # free again once the holder exits
        pass


def test_wait_blocks_until_the_holder_is_done(tmp_path):
    proc = _holder(tmp_path)
    waited = []
    got = threading.Event()

    def take() -> None:
        with DatasetLock(tmp_path, wait=True, on_wait=lambda pid, host: waited.append(pid)):
            got.set()
            time.sleep(0.2)

    thread = threading.Thread(target=take)
    thread.start()
    try:
        time.sleep(0.5)
        assert not got.is_set() and waited == [proc.pid]
    finally:
        proc.communicate("")
    thread.join(timeout=30)
    assert got.is_set() and waited == [proc.pid]
    assert not (tmp_path / LOCK_FILE).exists()


def test_lock_of_a_killed_holder_is_free(tmp_path):
    proc = _holder(tmp_path)
    proc.kill()  # SIGKILL: the file stays, the OS lock goes
    proc.wait()
    proc.stdin.close()
    proc.stdout.close()
    assert read_holder(tmp_path)[0] == proc.pid
    with DatasetLock(tmp_path):
        assert read_holder(tmp_path)[0] == os.getpid()


def test_unwritable_folder_is_one_line_error(tmp_path):
    with pytest.raises(UserError, match=r"^cannot write to .*missing: No such file"):
        DatasetLock(tmp_path / "missing").acquire()
