"""processes: the one CPU count and the one parent-death signal request."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from trossen_arm_mujoco import processes
from trossen_arm_mujoco.processes import available_cpus, parent_death_signal


def test_available_cpus_is_the_affinity(monkeypatch):
    assert available_cpus() >= 1
    if hasattr(os, "sched_getaffinity"):
        assert available_cpus() == len(os.sched_getaffinity(0))
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(), raising=False)
    assert available_cpus() == 1  # never 0
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)  # not Linux
    monkeypatch.setattr(os, "cpu_count", lambda: None)
    assert available_cpus() == 1


def test_the_users_of_a_cpu_count_share_it(monkeypatch):
    """record's --num_workers cap, eval's thread share and the compressor's threads."""
    import argparse

    from trossen_arm_mujoco.data import chunk_compressor
    from trossen_arm_mujoco.eval import runner
    from trossen_arm_mujoco.scripts import record_args

    for module in (chunk_compressor, runner, record_args):
        assert module.available_cpus is processes.available_cpus
    monkeypatch.setattr(chunk_compressor, "available_cpus", lambda: 3)
    assert chunk_compressor.default_workers() == 3
    monkeypatch.setattr(record_args, "available_cpus", lambda: 2)
    args = argparse.Namespace(num_workers=5, engine="local", ray_address=None)
    assert record_args.num_workers(args) == 2


#: A child asks for SIGUSR1 at its parent's death and reads it back (PR_GET_PDEATHSIG, 2).
CHILD = """
import ctypes, signal
from trossen_arm_mujoco.processes import parent_death_signal
request = parent_death_signal(signal.SIGUSR1)
assert request is not None and request() is True
got = ctypes.c_int(0)
ctypes.CDLL(None).prctl(2, ctypes.byref(got), 0, 0, 0)
print(got.value)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_the_parent_death_signal_is_granted():
    out = subprocess.run(
        [sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=60, check=True
    )
    assert int(out.stdout) == int(signal.SIGUSR1)


def test_no_parent_death_signal_off_linux(monkeypatch):
    monkeypatch.setattr(sys, "platform", "darwin")
    assert parent_death_signal() is None
