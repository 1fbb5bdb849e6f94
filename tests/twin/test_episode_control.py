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
