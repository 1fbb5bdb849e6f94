"""The episode control channel (``twin.episode_control``): JSON lines on loopback; start places
the scene of ``record --seed S`` (or the objects the client sends), status and end report the
score the world computed; bad requests get ``ok: false``, bad addresses one-line errors."""

from __future__ import annotations

import json
import socket

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.twin.episode_control import EpisodeControl
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
    ],
)
def test_bad_requests_are_answered_not_fatal(channel, line: str, error: str) -> None:
    world, control, client = channel
    reply = client.send(line)
    assert reply["ok"] is False and error in reply["error"]
    assert client.ask(cmd="status")["ok"]  # the channel and the world go on


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
