"""``serve --cameras ... --control_port P``: the rehearsal parts of the served kit (cameras over
ZeroMQ, episode control), on 127.0.0.141 / 127.0.0.142 and free loopback ports; mistakes are
one line and exit 2; with ``--record``, one episode file per start .. end."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from trossen_arm_mujoco.scripts import serve

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "trossen_arm_mujoco" / "scripts" / "serve.py"
LEFT, RIGHT = "127.0.0.141", "127.0.0.142"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def one_line_error(argv: list[str], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> str:
    rc = serve.cli(["--left_ip", LEFT, "--right_ip", RIGHT, *argv, "--root_dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--camera_port", "6000"], "--camera_port needs --cameras NAMES"),
        (
            ["--cameras", "cam_high", "--camera_host", "192.168.1.5"],
            "--camera_host '192.168.1.5' is not an IPv4 loopback address",
        ),
        (["--cameras", "cam_high", "--camera_host", "0.0.0.0"], "not an IPv4 loopback address"),
        (
            ["--control_port", "6001", "--control_host", "10.1.2.3"],
            "--control_host '10.1.2.3' is not an IPv4 loopback address",
        ),
        (["--cameras", "cam_nope"], "unknown camera 'cam_nope'; valid cameras:"),
        (["--cameras", "cam_high", "--image_size", "48"], "--image_size must look like"),
        (
            ["--role", "leader", "--replay", "x.hdf5", "--cameras", "cam_high"],
            "--cameras and --control_port need --role follower",
        ),
    ],
)
def test_mistakes_are_one_line_exit_2(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("zmq")
    line = one_line_error(argv, capsys, tmp_path)
    assert expected in line, line


def test_ports_in_use_are_one_line_exit_2(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("zmq")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = str(taken.getsockname()[1])
        line = one_line_error(
            ["--cameras", "cam_high", "--image_size", "48x64", "--camera_port", port],
            capsys,
            tmp_path,
        )
        assert "choose another --camera_port" in line
        line = one_line_error(["--control_port", port], capsys, tmp_path)
        assert "choose another --control_port" in line


def test_missing_pyzmq_names_the_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    pytest.importorskip("trossen_arm_sim")
    monkeypatch.setitem(sys.modules, "zmq", None)
    line = one_line_error(["--cameras", "cam_high"], capsys, tmp_path)
    assert "pip install 'trossen-arm-mujoco[cameras]'" in line


def test_record_keeps_one_episode_per_start_and_end(tmp_path: Path) -> None:
    pytest.importorskip("trossen_arm_sim")
    from trossen_arm_mujoco.data.reader import list_episodes, load_episode

    port = free_port()
    proc = subprocess.Popen(
        [
            sys.executable,
            str(SCRIPT),
            "--left_ip",
            LEFT,
            "--right_ip",
            RIGHT,
            "--record",
            str(tmp_path / "data"),
            "--cam_names",
            "none",
            "--control_port",
            str(port),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "MUJOCO_GL": "egl"},
    )
    try:
        first = proc.stdout.readline()
        assert first.startswith("serving ") and f"episode control on 127.0.0.1:{port}" in first
        with socket.create_connection(("127.0.0.1", port), timeout=20) as sock:
            f = sock.makefile("rwb")

            def ask(**request) -> dict:
                f.write((json.dumps(request) + "\n").encode())
                f.flush()
                return json.loads(f.readline())

            for seed in (3, 4):
                assert ask(cmd="start", seed=seed)["ok"]
                time.sleep(0.3)
                ended = ask(cmd="end")
                assert ended["ok"] and ended["frames"] >= 5, ended
                time.sleep(0.2)  # the recorder ends the episode at the next frame
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "episode started: seed 3" in out and "2 episode(s) written" in out, out
    found = list_episodes(tmp_path / "data")
    assert [k for k, _ in found] == [0, 1]
    seeds = [load_episode(p).attrs["base_seed"] for _, p in found]
    assert seeds == [3, 4]
