"""``trossen-mujoco serve``: the simulated kit served in a subprocess on 127.0.0.61 / 127.0.0.62,
driven by the installed ``trossen_arm`` driver; stopped by SIGINT or SIGTERM with exit 0.
Flag mistakes are checked in this process (one line, exit 2)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trossen_arm_mujoco import cli as top_cli
from trossen_arm_mujoco.scripts import serve

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "trossen_arm_mujoco" / "scripts" / "serve.py"
LEFT, RIGHT = "127.0.0.61", "127.0.0.62"
GOALS = {
    LEFT: [0.25, 0.6, 0.5, 0.2, -0.2, 0.3, 0.03],
    RIGHT: [-0.25, 0.5, 0.6, -0.2, 0.2, -0.3, 0.012],
}


class Served:
    """A ``serve`` subprocess; :meth:`stop` sends a signal and returns (rc, stdout, stderr)."""

    def __init__(self, *flags: str, env: dict[str, str] | None = None) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(SCRIPT), "--left_ip", LEFT, "--right_ip", RIGHT, *flags],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1", "MUJOCO_GL": "egl", **(env or {})},
        )
        self.first_line = self.proc.stdout.readline()
        if not self.first_line.startswith("serving "):
            out, err = self.proc.communicate(timeout=30)
            pytest.fail(f"serve did not start: {self.first_line}{out}{err}")

    def stop(self, signum: int = signal.SIGINT) -> tuple[int, str, str]:
        self.proc.send_signal(signum)
        out, err = self.proc.communicate(timeout=120)
        return self.proc.returncode, self.first_line + out, err

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


@pytest.fixture
def served() -> Iterator[Any]:
    pytest.importorskip("trossen_arm_sim")
    made: list[Served] = []

    def start(*flags: str, env: dict[str, str] | None = None) -> Served:
        made.append(Served(*flags, env=env))
        return made[-1]

    yield start
    for s in made:
        s.kill()


def drive_both_arms(hold: float = 0.0, timeout: float = 5.0) -> dict[str, np.ndarray]:
    """configure both arms (``timeout`` s each), position mode, a 1 s move each (gripper
    too), read back, cleanup; returns the measured positions."""
    ta = pytest.importorskip("trossen_arm")
    drivers, measured = {}, {}
    for ip in (LEFT, RIGHT):
        driver = ta.TrossenArmDriver()
        follower = ta.StandardEndEffector.wxai_v0_follower
        driver.configure(ta.Model.wxai_v0, follower, ip, True, timeout)
        driver.set_all_modes(ta.Mode.position)
        drivers[ip] = driver
    try:
        drivers[LEFT].set_all_positions(GOALS[LEFT], 1.0, False)
        drivers[RIGHT].set_all_positions(GOALS[RIGHT], 1.0, True)
        end = time.monotonic() + 3.0
        while time.monotonic() < end:  # settled, or what it reached within 3 s
            measured = {ip: np.asarray(d.get_all_positions()) for ip, d in drivers.items()}
            errors = [np.abs(measured[ip] - GOALS[ip]) for ip in drivers]
            if all(e[:6].max() <= 0.02 and e[6] <= 0.002 for e in errors):
                break
            time.sleep(0.05)
        time.sleep(hold)
    finally:
        for driver in drivers.values():
            driver.cleanup()
    return measured


def test_both_arms_follow_the_real_driver_and_sigint_exits_0(served) -> None:
    s = served()
    assert f"left arm on {LEFT}, right arm on {RIGHT}" in s.first_line
    measured = drive_both_arms()
    for ip in (LEFT, RIGHT):
        np.testing.assert_allclose(measured[ip][:6], GOALS[ip][:6], atol=0.02)
        assert abs(measured[ip][6] - GOALS[ip][6]) <= 0.002
    rc, out, err = s.stop(signal.SIGINT)
    assert rc == 0, err
    assert "Traceback" not in err and err.strip() == ""
    assert f"left arm ({LEFT}): client connected" in out
    assert "stopped (SIGINT)" in out


def test_sigterm_exits_0(served) -> None:
    rc, out, err = served().stop(signal.SIGTERM)
    assert rc == 0 and "stopped (SIGTERM)" in out
    assert "Traceback" not in err


def test_viewer_shows_the_kit_while_the_driver_moves_it(served, xscreen, tmp_path) -> None:
    s = served("--viewer", env={"DISPLAY": xscreen.display})
    # the world steps while the viewer syncs; the driver's own default wait (20 s): on a
    # fresh machine software GL shares the 2 cores with the first window's start
    measured = drive_both_arms(timeout=20.0)
    np.testing.assert_allclose(measured[LEFT][:6], GOALS[LEFT][:6], atol=0.02)
    colours = 0
    for _ in range(10):
        colours = xscreen.colours(tmp_path / "screen.xwd")
        if colours > 200:
            break
        time.sleep(1.0)
    rc, out, err = s.stop(signal.SIGTERM)
    assert rc == 0, err
    assert "live view off" not in out + err and "Traceback" not in err
    assert colours > 200, f"no screenshot shows the kit: {xscreen.report()}; serve: {err[-600:]}"


def test_record_one_session_into_one_episode(served, tmp_path: Path) -> None:
    from trossen_arm_mujoco.data.reader import list_episodes, load_episode

    s = served(
        "--record",
        str(tmp_path / "data"),
        "--cam_names",
        "cam_high",
        "--image_size",
        "48x64",
        "--fps",
        "50",
        "--seed",
        "5",
    )
    drive_both_arms(hold=0.2)
    time.sleep(0.5)  # the session's end reaches the recorder at the next frame
    rc, out, err = s.stop()
    assert rc == 0, err
    assert "Traceback" not in err
    found = list_episodes(tmp_path / "data")
    assert [i for i, _ in found] == [0]
    episode = load_episode(found[0][1], load_images=True)
    assert episode.num_steps >= 25 and episode.reward is not None
    assert episode.images["cam_high"].shape[1:] == (48, 64, 3)
    assert episode.attrs["task_name"] == "sim_transfer_cube" and episode.attrs["dt"] == 0.02
    # the recorded action is what the clients commanded: the last frames hold the goals
    np.testing.assert_allclose(episode.action[-1, 0:6], GOALS[LEFT][:6], atol=1e-5)
    np.testing.assert_allclose(episode.action[-1, 8:14], GOALS[RIGHT][:6], atol=1e-5)
    line = next(x for x in out.splitlines() if x.startswith("episode_0.hdf5: "))
    assert "session ended; reward final" in line and "no success" in line
    assert "1 episode(s) written" in out


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--left_ip", "192.168.1.5"], "--left_ip '192.168.1.5' is not an IPv4 loopback address"),
        (["--right_ip", "0.0.0.0"], "--right_ip '0.0.0.0' is not an IPv4 loopback address"),
        (["--left_ip", "127.0.0.63", "--right_ip", "127.0.0.63"], "are both 127.0.0.63"),
        (["--task_name", "mobile_pick_place"], "not a Stationary AI (two-arm) task"),
        (["--task_name", "reach", "--right_ip", "127.0.0.63"], "serves one arm"),
        (["--fps", "30"], "whole multiple"),
        (["--episode_len", "5"], "--episode_len needs --record DIR"),
        (["--replay", "x.hdf5"], "--replay needs --role leader"),
        (["--role", "leader"], "--role leader needs --replay"),
        (["--record", "d", "--role", "leader", "--replay", "x"], "--record needs --role follower"),
        (["--parent_pid", "0"], "--parent_pid must be a process id (at least 1), got 0"),
        (["--record", "d", "--cam_names", "cam_nope"], "unknown camera 'cam_nope'"),
    ],
)
def test_mistakes_are_one_line_exit_2(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    pytest.importorskip("trossen_arm_sim")
    handlers = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)]
    rc = serve.cli([*argv, "--root_dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    # nothing was served: this process's signal handlers are as they were
    assert [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)] == handlers
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], err


def test_a_parent_already_gone_stops_serve_before_it_serves(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--parent_pid`` names a process that is not serve's parent (eval --backend wire's,
    killed): serve stops as on a stop signal, exit 0, nothing served."""
    pytest.importorskip("trossen_arm_sim")
    handlers = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)]
    rc = serve.main(["--left_ip", LEFT, "--right_ip", RIGHT, "--parent_pid", str(os.getpid())])
    out = capsys.readouterr().out
    assert rc == 0 and out == "stopped (its parent process ended) before serving began\n"
    assert [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)] == handlers


def test_missing_trossen_arm_sim_gives_the_install_hint(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("trossen_arm_sim", "trossen_arm_sim.server"):
        monkeypatch.setitem(sys.modules, name, None)  # import fails as when not installed
    assert serve.cli([]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'trossen-arm-mujoco[twin]'" in err[0]


def test_listed_by_trossen_mujoco(capsys: pytest.CaptureFixture[str]) -> None:
    assert top_cli.main(["--help"]) == 0
    assert "serve        serve the simulated kit" in capsys.readouterr().out
    assert top_cli.SUBCOMMANDS["serve"] == "trossen_arm_mujoco.scripts.serve"
