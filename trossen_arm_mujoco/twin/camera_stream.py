"""The served kit's cameras over ZeroMQ, in LeRobot's ZMQ camera protocol (``type: zmq``).

A :class:`CameraStream` publishes the named cameras of a :class:`~.kit_world.KitWorld` on a
ZeroMQ PUB socket bound to ``tcp://HOST:PORT`` (HOST in 127.0.0.0/8 only), as LeRobot
0.6.1's ``ZMQCamera`` reads it: one JSON text per message with every camera's base64 JPEG
and the wall-clock time (s) of the state it shows. Its own thread renders a snapshot of the
state, so rendering never holds up the arms; :func:`decode_image` reads a message without
OpenCV and :class:`StreamStats` measures the publish rate and frame age.

Docs: docs/rehearsal.md (Cameras over ZeroMQ); details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import base64
import io
import json
import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.twin.kit_world import KitWorld
from trossen_arm_mujoco.twin.serving import check_loopback

__all__ = [
    "CAMERAS_HINT",
    "CameraStream",
    "StreamStats",
    "decode_image",
    "encode_image",
    "encode_message",
    "import_zmq",
]

log = logging.getLogger(__name__)

#: How to install what the stream needs.
CAMERAS_HINT = "pip install 'trossen-arm-mujoco[cameras]' (pyzmq)"
#: JPEG quality of the published images (LeRobot's image server uses 80).
JPEG_QUALITY = 80


def import_zmq() -> Any:
    """The ``zmq`` module (pyzmq), or a one-line ``UserError`` saying how to install it."""
    try:
        import zmq
    except ImportError:
        raise UserError(f"serving cameras needs pyzmq: {CAMERAS_HINT}") from None
    return zmq


def encode_image(rgb: np.ndarray, quality: int = JPEG_QUALITY) -> str:
    """uint8 RGB ``(H, W, 3)`` -> base64 JPEG text with red and blue swapped, as LeRobot's
    image server writes it (``ZMQCamera`` decodes it back to RGB; see the module doc)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb[..., ::-1])).save(buf, "JPEG", quality=quality)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def decode_image(text: str) -> np.ndarray:
    """:func:`encode_image`'s inverse: base64 JPEG text -> uint8 RGB ``(H, W, 3)``."""
    from PIL import Image

    with Image.open(io.BytesIO(base64.b64decode(text))) as img:
        swapped = np.asarray(img.convert("RGB"))
    return np.ascontiguousarray(swapped[..., ::-1])


def encode_message(images: dict[str, np.ndarray], stamp: float) -> str:
    """One message of the protocol: every image of ``images`` (RGB) with the timestamp
    ``stamp`` (wall-clock s)."""
    return json.dumps(
        {
            "timestamps": {name: stamp for name in images},
            "images": {name: encode_image(img) for name, img in images.items()},
        }
    )


@dataclass
class StreamStats:
    """What a stream measured: messages published, over how long, and each message's frame
    age (publish time minus the time the state was taken, s)."""

    published: int = 0
    seconds: float = 0.0
    ages: list[float] = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Messages published per wall-clock second."""
        return self.published / self.seconds if self.seconds > 0 else 0.0

    def age_ms(self, q: float) -> float:
        """Quantile ``q`` (0..1) of the frame age, in ms (nan before any message)."""
        return float(np.quantile(self.ages, q) * 1e3) if self.ages else float("nan")

    def line(self, fps: float) -> str:
        """One line for the log: rate against the asked one, median and 95th-percentile age."""
        return (
            f"cameras: {self.published} frames at {self.rate:.1f} per s (asked {fps:g}); "
            f"frame age median {self.age_ms(0.5):.1f} ms, p95 {self.age_ms(0.95):.1f} ms"
        )


class CameraStream:
    """Publishes ``cam_names`` of ``world`` over ZeroMQ; see the module doc.

    Args:
        world: the served world (read under its lock, never stepped here).
        cam_names: cameras of the model; an unknown one is a ``UserError`` listing them.
        height, width: image size (pixels).
        fps: messages per wall-clock second (at most; fewer when rendering cannot keep up).
        port: TCP port; one in use is a one-line ``UserError``.
        host: address in 127.0.0.0/8 to bind (anything else is refused).
    """

    def __init__(
        self,
        world: KitWorld,
        cam_names: Sequence[str],
        height: int,
        width: int,
        fps: float = 30.0,
        port: int = 5555,
        host: str = "127.0.0.1",
    ) -> None:
        from trossen_arm_mujoco.sim.cameras import CameraSet

        self.host = check_loopback(host, "--camera_host")
        if not 1 <= int(port) <= 65535:
            raise UserError(f"--camera_port must be in 1..65535, got {port}")
        if not (np.isfinite(fps) and 0 < fps <= 1000):
            raise UserError(f"--camera_fps must be in (0, 1000], got {fps:g}")
        names = list(cam_names)
        if not names:
            raise UserError("--cameras needs at least one camera name")
        valid = CameraSet.available(world.model)
        for name in names:
            if name not in valid:
                raise unknown_name_error("camera", name, valid)
        CameraSet(world.model, [], height, width)  # checks the size against the model
        self.world, self.cam_names = world, names
        self.height, self.width = int(height), int(width)
        self.fps, self.port = float(fps), int(port)
        self.stats = StreamStats()
        self._zmq = import_zmq()
        self._context = self._zmq.Context()
        self._socket = self._context.socket(self._zmq.PUB)
        self._socket.setsockopt(self._zmq.SNDHWM, 20)
        self._socket.setsockopt(self._zmq.LINGER, 0)
        try:
            self._socket.bind(f"tcp://{self.host}:{self.port}")
        except self._zmq.ZMQError as exc:
            self._socket.close()
            self._context.term()
            raise UserError(
                f"cannot serve cameras on {self.host}:{self.port} ({exc}); another program "
                "uses the port: choose another --camera_port"
            ) from None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    @property
    def address(self) -> str:
        """``tcp://host:port`` the stream is bound to."""
        return f"tcp://{self.host}:{self.port}"

    def start(self) -> CameraStream:
        """Publish in a daemon thread until :meth:`stop`."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="kit-cameras", daemon=True)
            self._thread.start()
        return self

    def _snapshot(self, rdata: mujoco.MjData) -> float:
        """Copy the world's state into ``rdata`` (under the world's lock); its wall time."""
        w = self.world
        with w.lock:
            rdata.qpos[:] = w.data.qpos
            rdata.mocap_pos[:], rdata.mocap_quat[:] = w.data.mocap_pos, w.data.mocap_quat
            stamp = time.time()
        mujoco.mj_forward(w.model, rdata)
        return stamp

    def _run(self) -> None:
        from trossen_arm_mujoco.sim.cameras import CameraSet

        cameras = CameraSet(self.world.model, self.cam_names, self.height, self.width)
        rdata = mujoco.MjData(self.world.model)
        period, started = 1.0 / self.fps, time.monotonic()
        next_at = started
        try:
            while not self._stop.is_set():
                stamp = self._snapshot(rdata)
                message = encode_message(cameras.render_all(rdata), stamp)
                try:
                    self._socket.send_string(message, self._zmq.NOBLOCK)
                except self._zmq.Again:  # no subscriber keeps up: drop, as LeRobot's server
                    pass
                self.stats.ages.append(time.time() - stamp)
                self.stats.published += 1
                self.stats.seconds = time.monotonic() - started
                next_at = max(next_at + period, time.monotonic())
                self._stop.wait(max(0.0, next_at - time.monotonic()))
        except Exception as exc:  # reported by stop() and the log, never silently
            self.error = exc
            log.error("camera stream stopped: %s", exc)
        finally:
            cameras.close()

    def stop(self) -> StreamStats:
        """Stop publishing, close the socket (idempotent); the measured figures."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None
        if not self._socket.closed:
            self._socket.close()
            self._context.term()
        return self.stats
