"""Every stop of ``trossen-mujoco serve`` is safe (ARCHITECTURE principle 16): a ``serve
--record`` subprocess on 127.0.0.111 / 127.0.0.112, driven by two live ``trossen_arm``
drivers streaming positions, stopped by two signals 50 ms apart in any order, exits 0 with
its episode written and valid and no temporary file left; idle, likewise; killed (SIGKILL),
its spool is published by the next start, never deleted."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "trossen_arm_mujoco" / "scripts" / "serve.py"
LEFT, RIGHT = "127.0.0.111", "127.0.0.112"
#: Cameras and size recorded (small: the runs stay short).
RECORD_FLAGS = ("--cam_names", "cam_high", "--image_size", "48x64", "--fps", "50")
#: How long a stopped serve may take to exit (s): writing a short episode, on a busy machine.
EXIT_S = 60.0


class Serve:
    """A ``serve`` subprocess; the lines before ``serving ...`` are kept in :attr:`head`."""

    def __init__(self, *flags: str) -> None:
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-X",
                "faulthandler",
                str(SCRIPT),
                "--left_ip",
                LEFT,
                "--right_ip",
                RIGHT,
                *flags,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1", "MUJOCO_GL": "egl"},
        )
        self.head: list[str] = []
        for line in self.proc.stdout:
            self.head.append(line)
            if line.startswith("serving "):
                return
        out, err = self.proc.communicate(timeout=EXIT_S)
        pytest.fail(f"serve did not start: {''.join(self.head)}{out}{err}")

    def signal(self, *signums: int, gap: float = 0.05) -> tuple[int, str, str]:
        """Send ``signums`` ``gap`` s apart; (exit status, stdout, stderr)."""
        for i, signum in enumerate(signums):
            if i:
                time.sleep(gap)
            self.proc.send_signal(signum)
        out, err = self.proc.communicate(timeout=EXIT_S)
        return self.proc.returncode, "".join(self.head) + out, err

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


class Clients:
    """Both arms configured through the real ``trossen_arm`` driver, streaming position
    targets (a slow sway of joint 0 around where the arm is) in a thread until stopped."""

    def __init__(self) -> None:
        ta = pytest.importorskip("trossen_arm")
        self.drivers: list[Any] = []
        for ip in (LEFT, RIGHT):
            driver = ta.TrossenArmDriver()
            self.drivers.append(driver)
            driver.configure(
                ta.Model.wxai_v0, ta.StandardEndEffector.wxai_v0_follower, ip, True, 5.0
            )
            driver.set_all_modes(ta.Mode.position)
        self.starts = [np.asarray(d.get_all_positions(), dtype=float) for d in self.drivers]
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._stream, daemon=True)
        self._thread.start()

    def _stream(self) -> None:
        t0 = time.monotonic()
        while not self._stop.is_set():
            sway = 0.1 * np.sin(2.0 * (time.monotonic() - t0))
            try:
                for driver, start in zip(self.drivers, self.starts, strict=True):
                    goal = start.copy()
                    goal[0] += sway
                    driver.set_all_positions(goal.tolist(), 0.0, False)
            except Exception:  # the server went away: the test's business, not the stream's
                return
            self.sent += 1
            self._stop.wait(0.02)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(10.0)
        for driver in self.drivers:
            try:
                driver.cleanup()
            except Exception:
                pass
        self.drivers.clear()


@pytest.fixture
def serve() -> Iterator[Any]:
    pytest.importorskip("trossen_arm_sim")
    made: list[Any] = []

    def start(*flags: str) -> Serve:
        made.append(Serve(*flags))
        return made[-1]

    yield start
    for s in made:
        s.kill()


@pytest.fixture
def clients() -> Iterator[Any]:
    made: list[Clients] = []

    def connect() -> Clients:
        made.append(Clients())
        return made[-1]

    yield connect
    for c in made:
        c.close()


def streaming(connect: Any, seconds: float = 1.0) -> Clients:
    """Clients connected and streaming for ``seconds``."""
    c = connect()
    time.sleep(seconds)
    assert c.sent > 5, "the clients did not stream"
    return c


def wait_for_spooled_steps(folder: Path, steps: int, timeout: float = 30.0) -> int:
    """Wait until the one spool in ``folder`` holds at least ``steps`` steps; returns how
    many it holds."""
    from trossen_arm_mujoco.twin.spool_recovery import read_spool

    end = time.monotonic() + timeout
    held = 0
    while time.monotonic() < end:
        for path in folder.glob(".serve_spool.*.tmp"):
            held = read_spool(path).steps
        if held >= steps:
            return held
        time.sleep(0.1)
    pytest.fail(f"the spool holds {held} steps after {timeout} s")


def temp_files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.glob(".*") if p.name != ".lock")


def check_written(folder: Path, min_steps: int) -> Any:
    """The folder holds exactly episode_0, valid (read back by the project's reader)."""
    from trossen_arm_mujoco.data.reader import list_episodes, load_episode

    found = list_episodes(folder)
    assert [i for i, _ in found] == [0], sorted(p.name for p in folder.iterdir())
    episode = load_episode(found[0][1], load_images=True)
    assert episode.num_steps >= min_steps
    assert episode.images["cam_high"].shape == (episode.num_steps, 48, 64, 3)
    assert episode.images["cam_high"].std() > 0
    assert np.all(np.isfinite(episode.action))
    return episode


CASES = {
    "SIGTERM,SIGTERM": (signal.SIGTERM, signal.SIGTERM),
    "SIGINT,SIGINT": (signal.SIGINT, signal.SIGINT),
    "SIGINT,SIGTERM": (signal.SIGINT, signal.SIGTERM),
}


@pytest.mark.parametrize("run", range(3))
@pytest.mark.parametrize("case", list(CASES))
def test_two_signals_with_a_streaming_client_write_the_episode(
    case: str, run: int, serve, clients, tmp_path: Path
) -> None:
    folder = tmp_path / "data"
    s = serve("--record", str(folder), *RECORD_FLAGS)
    c = streaming(clients)
    spooled = wait_for_spooled_steps(folder, 10)
    rc, out, err = s.signal(*CASES[case])
    c.close()
    first = signal.Signals(CASES[case][0]).name
    assert rc == 0, f"exit {rc}; stdout: {out[-1500:]}; stderr: {err[-3000:]}"
    assert "Traceback" not in err and "Fatal Python error" not in err, err[-3000:]
    assert f"stopped ({first})" in out and "1 episode(s) written" in out, out
    assert "episode_0.hdf5: " in out and "serve stopped" in out
    episode = check_written(folder, min_steps=spooled)
    assert episode.attrs["end_reason"] == "serve stopped"
    assert temp_files(folder) == []


def test_idle_serve_exits_0_after_two_sigterms(serve) -> None:
    rc, out, err = serve().signal(signal.SIGTERM, signal.SIGTERM)
    assert rc == 0, f"exit {rc}: {err[-2000:]}"
    assert "stopped (SIGTERM)" in out and "Traceback" not in err


def test_idle_recording_serve_exits_0_after_many_signals(serve, tmp_path: Path) -> None:
    folder = tmp_path / "data"
    s = serve("--record", str(folder), *RECORD_FLAGS)
    sigs = (signal.SIGINT, signal.SIGTERM, signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    rc, out, err = s.signal(*sigs, gap=0.01)
    assert rc == 0, f"exit {rc}: {err[-2000:]}"
    assert "stopped (SIGINT)" in out and "0 episode(s) written" in out
    assert "Traceback" not in err
    assert temp_files(folder) == []


def test_a_killed_serve_leaves_its_episode_to_the_next_start(serve, clients, tmp_path) -> None:
    from trossen_arm_mujoco.data.reader import load_episode
    from trossen_arm_mujoco.twin.spool_recovery import read_spool

    folder = tmp_path / "data"
    s = serve("--record", str(folder), *RECORD_FLAGS)
    c = streaming(clients)
    spooled = wait_for_spooled_steps(folder, 20)  # frames still queued in memory are lost
    s.proc.kill()  # SIGKILL: nothing runs, nothing is written
    s.proc.communicate(timeout=EXIT_S)
    c.close()
    spools = list(folder.glob(".serve_spool.*.tmp"))
    assert len(spools) == 1 and read_spool(spools[0]).steps >= spooled
    assert not list(folder.glob("episode_*.hdf5"))

    again = serve("--record", str(folder), *RECORD_FLAGS)  # recovers before serving
    head = "".join(again.head)
    assert "episode_0.hdf5: recovered " in head and spools[0].name in head, head
    assert "episode 1)" in again.head[-1]  # it serves the next episode
    assert not spools[0].exists()
    rc, out, err = again.signal(signal.SIGTERM)
    assert rc == 0 and "Traceback" not in err, err[-2000:]
    episode = check_written(folder, min_steps=spooled)
    assert episode.attrs["end_reason"].startswith("recovered")
    assert episode.attrs["task_name"] == "sim_transfer_cube" and episode.attrs["source"] == "serve"
    assert temp_files(folder) == []
    loaded = load_episode(folder / "episode_0.hdf5")
    assert loaded.attrs["recovered_from"] == spools[0].name


def test_signals_while_waiting_for_the_dataset_lock_exit_0(tmp_path: Path) -> None:
    pytest.importorskip("trossen_arm_sim")
    from trossen_arm_mujoco.data.dataset_lock import DatasetLock

    folder = tmp_path / "data"
    folder.mkdir()
    with DatasetLock(folder):  # another run writes there: serve --wait waits
        proc = subprocess.Popen(
            [
                sys.executable,
                str(SCRIPT),
                "--left_ip",
                LEFT,
                "--right_ip",
                RIGHT,
                "--record",
                str(folder),
                "--wait",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1", "MUJOCO_GL": "egl"},
        )
        try:
            time.sleep(3.0)  # started and waiting
            assert proc.poll() is None, proc.communicate()
            proc.send_signal(signal.SIGINT)
            time.sleep(0.05)
            proc.send_signal(signal.SIGTERM)
            out, err = proc.communicate(timeout=EXIT_S)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    assert proc.returncode == 0, err
    assert "stopped (SIGINT) before serving began" in out and "Traceback" not in err
