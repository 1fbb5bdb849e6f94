"""The kit's camera stream (``twin.camera_stream``): LeRobot's ZMQ camera protocol on loopback,
read by a plain ZeroMQ subscriber here and by LeRobot's own ``ZMQCamera`` in the 3.12 venv
(``TROSSEN_LEROBOT_PYTHON``); refusals as one-line errors. Tiny images (48x64)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import time

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError

zmq = pytest.importorskip("zmq")

from trossen_arm_mujoco.twin.camera_stream import (  # noqa: E402
    CameraStream,
    decode_image,
    encode_image,
)
from trossen_arm_mujoco.twin.kit_world import KitWorld  # noqa: E402

CAMS = ("cam_high", "cam_left_wrist")
H, W = 48, 64


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def world():
    w = KitWorld()
    yield w
    w.close()


def receive(port: int, timeout_ms: int = 10_000) -> dict:
    ctx = zmq.Context()
    sock = ctx.socket(zmq.SUB)
    sock.setsockopt_string(zmq.SUBSCRIBE, "")
    sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
    sock.connect(f"tcp://127.0.0.1:{port}")
    try:
        return json.loads(sock.recv_string())
    finally:
        sock.close(0)
        ctx.term()


def test_jpeg_round_trip_keeps_rgb() -> None:
    img = np.zeros((H, W, 3), np.uint8)
    img[..., 0] = 200  # red
    back = decode_image(encode_image(img))
    assert back.shape == (H, W, 3)
    assert abs(back[..., 0].mean() - 200) < 5 and back[..., 2].mean() < 5


def test_stream_publishes_every_camera_at_the_size(world) -> None:
    port = free_port()
    stream = CameraStream(world, CAMS, H, W, fps=20, port=port).start()
    try:
        t0 = time.time()
        msg = receive(port)
        assert set(msg) == {"timestamps", "images"}
        assert set(msg["images"]) == set(CAMS) == set(msg["timestamps"])
        for cam in CAMS:
            img = decode_image(msg["images"][cam])
            assert img.shape == (H, W, 3) and img.dtype == np.uint8
            assert img.std() > 1.0  # a rendered scene, not a blank image
            assert abs(msg["timestamps"][cam] - t0) < 30
        # the image shows the world's state: the same render in this thread matches it
        from trossen_arm_mujoco.sim.cameras import CameraSet

        with world.lock:
            direct = CameraSet(world.model, ["cam_high"], H, W)
            ref = direct.render(world.data, "cam_high").astype(float)
            direct.close()
        got = decode_image(receive(port)["images"]["cam_high"]).astype(float)
        assert np.abs(got - ref).mean() < 12  # JPEG loss only; swapped channels differ more
    finally:
        stats = stream.stop()
    assert stream.error is None
    assert stats.published >= 2 and len(stats.ages) == stats.published
    assert 0 <= stats.age_ms(0.5) < 5000
    assert "frame age median" in stats.line(20)


def test_lerobot_zmq_camera_reads_each_camera(world) -> None:
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python:
        pytest.skip("TROSSEN_LEROBOT_PYTHON is not set to a Python with LeRobot (.ci/run sets it)")
    probe = subprocess.run([python, "-c", "import zmq, lerobot.cameras.zmq"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip("pyzmq is not installed next to LeRobot (pip install '.[cameras]' there)")
    port = free_port()
    script = f"""
import json
from lerobot.cameras.zmq import ZMQCamera, ZMQCameraConfig
out = {{}}
for name in {list(CAMS)!r}:
    cam = ZMQCamera(ZMQCameraConfig(server_address="127.0.0.1", port={port}, camera_name=name))
    cam.connect()
    img = cam.read()
    out[name] = [list(img.shape), str(img.dtype), img.reshape(-1, 3).mean(0).tolist()]
    cam.disconnect()
print(json.dumps(out))
"""
    stream = CameraStream(world, CAMS, H, W, fps=20, port=port).start()
    try:
        done = subprocess.run([python, "-c", script], capture_output=True, text=True, timeout=120)
        ours = {c: decode_image(receive(port)["images"][c]) for c in CAMS}
    finally:
        stream.stop()
    assert done.returncode == 0, done.stderr[-2000:]
    got = json.loads(done.stdout.strip().splitlines()[-1])
    for cam in CAMS:
        shape, dtype, mean = got[cam]
        assert shape == [H, W, 3] and dtype == "uint8"
        # LeRobot's decode gives the same channel order as ours: RGB
        assert np.allclose(mean, ours[cam].reshape(-1, 3).mean(0), atol=6)


def test_refusals_are_one_line_errors(world) -> None:
    with pytest.raises(UserError, match="unknown camera 'cam_nope'; valid cameras: .*cam_high"):
        CameraStream(world, ["cam_nope"], H, W, port=free_port())
    for host in ("0.0.0.0", "192.168.1.5", "localhost"):
        with pytest.raises(UserError, match="not an IPv4 loopback address"):
            CameraStream(world, CAMS, H, W, port=free_port(), host=host)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        with pytest.raises(UserError, match="choose another --camera_port"):
            CameraStream(world, CAMS, H, W, port=taken.getsockname()[1])
    with pytest.raises(UserError, match="--camera_fps"):
        CameraStream(world, CAMS, H, W, fps=0, port=free_port())
