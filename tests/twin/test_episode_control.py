"""The episode control channel (``twin.episode_control``): JSON lines on loopback; start places
the scene of ``record --seed S`` (or the objects the client sends), status and end report the
score the world computed; bad requests get ``ok: false``, bad addresses one-line errors."""

from __future__ import annotations

import io
import json
import socket

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.twin.episode_control import (
    MAX_LINE,
    EpisodeControl,
    read_request,
    skip_line,
)
from trossen_arm_mujoco.twin.kit_world import KitWorld


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Client:
    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=20)
        self.file = self.sock.makefile("rwb")

    def send(self, line: str) -> dict:
        self.file.write(line.encode() + b"\n")
        self.file.flush()
        return json.loads(self.file.readline())

    def ask(self, **request) -> dict:
        return self.send(json.dumps(request))

    def close(self) -> None:
        self.file.close()
        self.sock.close()


@pytest.fixture
def channel():
    world = KitWorld()
    control = EpisodeControl(world, free_port()).start()
    world.start()
    client = Client(control.port)
    yield world, control, client
    client.close()
    control.stop()
    world.close()


def test_start_places_the_record_scene_and_end_scores(channel) -> None:
    world, control, client = channel
    idle = client.ask(cmd="status")
    assert idle["ok"] and not idle["running"] and idle["task"] == "sim_transfer_cube"
    started = client.ask(cmd="start", seed=7, episode=2)
    assert started["ok"] and started["running"] and started["seed"] == 7
    assert started["episode"] == 2
    ref = KitWorld(base_seed=7, episode_index=2)  # the scene record --seed 7 gives episode 2
    try:
        assert np.allclose(started["env_state"], ref.env_state(), atol=1e-9)
    finally:
        ref.close()
    assert started["object_names"] == ["box"] and started["task_max_reward"] == 4.0
    ended = client.ask(cmd="end")
    assert ended["ok"] and not ended["running"] and ended["frames"] >= 1
    assert ended["max_reward"] == 0.0 and ended["success"] is False and ended["stages"] == {}
    again = client.ask(cmd="end")
    assert not again["ok"] and "no episode is running" in again["error"]


def test_start_with_object_poses_and_reward_levels(channel) -> None:
    world, control, client = channel
    pose = [0.0, 0.1, 0.05, 1.0, 0.0, 0.0, 0.0]
    started = client.ask(cmd="start", seed=1, object_poses={"box": pose})
    assert started["ok"]
    assert np.allclose(started["env_state"][:3], pose[:3], atol=1e-3)
    # the tracker scores what the world reports each frame
    with world.lock:
        world.task.get_reward = lambda: 2.0  # reward stage 2 from now on
    while client.ask(cmd="status")["frames"] < 3:
        pass
    status = client.ask(cmd="status")
    assert status["reward"] == 2.0 and status["max_reward"] == 2.0
    assert set(status["stages"]) == {"1", "2"} and status["sum_reward"] >= 4.0
    ended = client.ask(cmd="end")
    assert ended["max_reward"] == 2.0 and not ended["success"]


@pytest.mark.parametrize(
    "line, error",
    [
        ("not json", "not a JSON line"),
        ('{"cmd": "jump"}', 'expected {"cmd"'),
        ('{"cmd": "start", "seed": -1}', "seed must be an int"),
        ('{"cmd": "start", "seed": 1.5}', "seed must be an int"),
        ('{"cmd": "start", "object_poses": {"ball": [0,0,0,1,0,0,0]}}', "unknown object 'ball'"),
        ('{"cmd": "start", "object_poses": {"box": [0, 0]}}', "7 finite numbers"),
        (
            '{"cmd": "start", "object_poses": {"box": [1e30, 0, 0.05, 1, 0, 0, 0]}}',
            "start: the pose of 'box': position [1e+30, 0.0, 0.05] is outside the task's "
            "workspace [-0.8, 0.8] x [-0.8, 0.8] x [-0.1, 0.9] m",
        ),
        (
            '{"cmd": "start", "object_poses": {"box": [0, 0.1, -5, 1, 0, 0, 0]}}',
            "outside the task's workspace",
        ),
        (
            '{"cmd": "start", "object_poses": {"box": [0, 0.1, 0.05, 0, 0, 0, 1e-9]}}',
            "start: the pose of 'box' needs a non-zero quaternion",
        ),
        ("[" * 5000, "request nested deeper than 16 levels: refused"),
        ('{"cmd": "start", "seed": 1, "x": ' + "[" * 17 + "]" * 17 + "}", "nested deeper than 16"),
    ],
)
def test_bad_requests_are_answered_not_fatal(channel, line: str, error: str) -> None:
    world, control, client = channel
    reply = client.send(line)
    assert reply["ok"] is False and error in reply["error"], reply
    assert "\n" not in reply["error"]
    status = client.ask(cmd="status")
    assert status["ok"] and not status["running"]  # the channel and the world go on, unstarted


def test_brackets_inside_strings_do_not_count_as_nesting(channel) -> None:
    world, control, client = channel
    reply = client.send('{"cmd": "status", "note": "' + "[" * 100 + '"}')
    assert reply["ok"] is True


def test_an_over_long_line_is_refused_before_it_ends_and_then_dropped(channel) -> None:
    """More than 64 KiB without a newline: refused as soon as the limit is passed (the reply
    comes while the line is still unfinished), the rest is read to its newline and dropped,
    and the next request is served."""
    world, control, client = channel
    client.sock.sendall(b"x" * (MAX_LINE + 10_000))  # no newline yet
    reply = json.loads(client.file.readline())
    assert reply == {
        "ok": False,
        "error": f"request line longer than {MAX_LINE} bytes: refused (one JSON object per line)",
    }
    client.sock.sendall(b"y" * (3 * MAX_LINE) + b"\n")  # the rest of that line
    assert client.ask(cmd="status")["ok"]


class ChunkReader(io.RawIOBase):
    """A stream of ``size`` bytes of ``fill`` then a newline and ``tail``, produced as read
    (nothing held); counts the bytes read."""

    def __init__(self, size: int, fill: bytes = b"[", tail: bytes = b"") -> None:
        self.left, self.fill, self.tail, self.read_bytes = size, fill, tail, 0

    def readable(self) -> bool:
        return True

    def readinto(self, buf) -> int:
        if self.left > 0:
            n = min(len(buf), self.left)
            buf[:n] = self.fill * n
            self.left -= n
        elif self.left == 0:
            data = b"\n" + self.tail
            n = len(data)
            buf[:n] = data
            self.left = -1
        else:
            return 0
        self.read_bytes += n
        return n


def test_read_request_holds_at_most_the_limit_of_a_long_line() -> None:
    raw = ChunkReader(32 * 1024 * 1024, tail=b'{"cmd": "status"}\n')  # a 32 MB line
    reader = io.BufferedReader(raw)
    line, too_long = read_request(reader)
    assert too_long and len(line) == MAX_LINE  # refused after 64 KiB, not 32 MB
    assert raw.read_bytes < 2 * MAX_LINE
    skip_line(reader)  # the rest is dropped, a chunk at a time
    assert read_request(reader) == (b'{"cmd": "status"}\n', False)
    assert read_request(reader) is None


def test_refusals_are_one_line_errors() -> None:
    world = KitWorld()
    try:
        for host in ("0.0.0.0", "10.0.0.1"):
            with pytest.raises(UserError, match="not an IPv4 loopback address"):
                EpisodeControl(world, free_port(), host=host)
        with socket.socket() as taken:
            taken.bind(("127.0.0.1", 0))
            taken.listen(1)
            with pytest.raises(UserError, match="choose another --control_port"):
                EpisodeControl(world, taken.getsockname()[1])
    finally:
        world.close()


# -- a burst of clients, and a server out of file descriptors ---------------------------------
def test_a_burst_of_32_clients_connecting_at_once_is_served() -> None:
    """32 clients connect at once before any is accepted (the listener's backlog holds them;
    with the backlog of 4 it had, the fifth and later connects timed out), then each gets
    its answer."""
    import threading

    world = KitWorld()
    control = EpisodeControl(world, free_port())  # listening, not accepting yet
    n, clients, errors = 32, [], []
    go = threading.Barrier(n)

    def connect() -> None:
        try:
            go.wait(10)
            clients.append(socket.create_connection(("127.0.0.1", control.port), timeout=3))
        except OSError as exc:
            errors.append(exc)

    threads = [threading.Thread(target=connect) for _ in range(n)]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join(30)
        assert not errors and len(clients) == n, errors
        control.start()
        for sock in clients:
            sock.sendall(b'{"cmd": "status"}\n')
        for sock in clients:
            with sock.makefile("rb") as f:
                assert json.loads(f.readline())["ok"] is True
    finally:
        for sock in clients:
            sock.close()
        control.stop()
        world.close()


def test_an_accept_out_of_descriptors_refuses_that_client_and_serving_goes_on(caplog) -> None:
    """EMFILE from accept (the waiting client stays queued): one log line, a pause, and the
    next accept serves on; another error is the listener's end (stop), as before."""
    import errno
    import logging

    from trossen_arm_mujoco.twin.serving import Acceptor

    class Conn:
        def setsockopt(self, *args) -> None:
            pass

        def close(self) -> None:
            pass

    conn = Conn()

    class Listener:  # fails twice for want of descriptors, then accepts
        def __init__(self) -> None:
            self.calls = 0

        def accept(self):
            self.calls += 1
            if self.calls <= 4:  # twice, each time again when the spare is let go
                raise OSError(errno.EMFILE, "Too many open files")
            return conn, ("127.0.0.1", 1)

    pauses: list[float] = []
    log = logging.getLogger("test.acceptor")
    acceptor = Acceptor(Listener(), "control channel", log, pauses.append, pause=0.01)
    try:
        with caplog.at_level(logging.WARNING, logger="test.acceptor"):
            assert acceptor.accept() is None and acceptor.accept() is None
            assert acceptor.accept() is conn
        assert [r.getMessage() for r in caplog.records] == [
            "control channel: cannot accept a connection (Too many open files (EMFILE)): "
            "refused it; still serving"
        ]
        assert acceptor.refused == 2 and pauses == [0.01, 0.01]

        class Shut:
            def accept(self):
                raise OSError(errno.EBADF, "Bad file descriptor")

        with pytest.raises(OSError):
            Acceptor(Shut(), "x", log).accept()
    finally:
        acceptor.close()


#: A control channel in a process allowed few file descriptors: prints its port, serves
#: until its stdin closes.
LOW_LIMIT = """
import logging, os, resource, sys
logging.basicConfig(format="%(name)s: %(message)s")
from trossen_arm_mujoco.twin.episode_control import EpisodeControl
from trossen_arm_mujoco.twin.kit_world import KitWorld

world = KitWorld()
control = EpisodeControl(world, int(sys.argv[1])).start()
_, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, (len(os.listdir("/proc/self/fd")) + 4, hard))
print("serving", flush=True)
sys.stdin.read()
control.stop()
"""


def test_a_control_channel_out_of_descriptors_keeps_serving(tmp_path) -> None:
    """Far more clients than descriptors: the ones beyond the limit are refused, one line is
    logged, and once clients leave a new one is served as before."""
    import subprocess
    import sys
    import time

    port = free_port()
    script = tmp_path / "low_limit.py"
    script.write_text(LOW_LIMIT)
    proc = subprocess.Popen(
        [sys.executable, str(script), str(port)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    clients: list[socket.socket] = []
    try:
        assert proc.stdout.readline().strip() == "serving"
        answered = 0
        for _ in range(12):  # about 4 descriptors are left: most of these are refused
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=10)
                clients.append(sock)
                sock.sendall(b'{"cmd": "status"}\n')
                answered += json.loads(sock.makefile("rb").readline() or b"null") is not None
            except (OSError, ValueError):
                pass  # refused: reset or closed
        assert 1 <= answered < 12
        for sock in clients:
            sock.close()
        clients.clear()
        deadline = 20
        for _ in range(deadline * 10):  # the served clients' descriptors come back
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
                    sock.sendall(b'{"cmd": "status"}\n')
                    reply = sock.makefile("rb").readline()
            except OSError:
                reply = b""
            if reply:
                break
            time.sleep(0.1)
        assert json.loads(reply)["ok"] is True
        assert proc.poll() is None  # still serving
    finally:
        for sock in clients:
            sock.close()
        proc.stdin.close()
        try:
            proc.wait(20)
        finally:
            if proc.poll() is None:
                proc.kill()
    err = proc.stderr.read()
    assert proc.returncode == 0, err
    lines = [line for line in err.splitlines() if "cannot accept a connection" in line]
    assert lines and lines[0].endswith(
        "control channel: cannot accept a connection (Too many open files (EMFILE)): "
        "refused it; still serving"
    ), err
    assert "Traceback" not in err, err
