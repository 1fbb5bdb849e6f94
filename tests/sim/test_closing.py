"""Objects registered with sim.closing are closed at exit, once, unless forgotten."""

from __future__ import annotations

import gc
import subprocess
import sys
import weakref

from trossen_arm_mujoco.sim import closing


class Thing:
    def __init__(self):
        self.closed = 0

    def close(self):
        self.closed += 1


def test_registered_objects_are_closed_once_and_forgotten_ones_not(monkeypatch):
    monkeypatch.setattr(closing, "_open", weakref.WeakSet())  # leave the session's alone
    a, b = Thing(), Thing()
    closing.close_at_exit(a)
    closing.close_at_exit(b)
    closing.forget(b)
    closing._close_all()
    closing._close_all()
    assert (a.closed, b.closed) == (1, 0)


def test_registration_does_not_keep_objects_alive(monkeypatch):
    monkeypatch.setattr(closing, "_open", weakref.WeakSet())
    thing = Thing()
    closing.close_at_exit(thing)
    del thing
    gc.collect()
    assert len(closing._open) == 0


def test_runs_at_interpreter_exit_before_atexit_callbacks():
    code = (
        "import atexit\n"
        "from trossen_arm_mujoco.sim import closing\n"
        "class T:\n"
        "    def close(self): print('closed', flush=True)\n"
        "t = T()\n"
        "closing.close_at_exit(t)\n"
        "atexit.register(lambda: print('atexit', flush=True))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["closed", "atexit"]
