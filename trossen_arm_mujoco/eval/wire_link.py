"""The client side of a served kit, for ``eval --backend wire``: the ``serve`` process, its
episode control channel, its camera stream and its arms through the ``trossen_arm`` driver.

:class:`KitLink` (addresses, ports, all IPv4 loopback) and :func:`start_kit` / :func:`stop_kit`
(``serve`` as a child that dies with this process); :class:`ControlClient` (the JSON-lines
channel of ``twin.episode_control``); :class:`CameraReader` (the newest image per camera and
its wall-clock timestamp, s); :class:`ArmPair` (both arms, or a single arm's one, in position
mode: 7 values per arm, 6 joints rad then the gripper m).

Docs: docs/rehearsal.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.processes import parent_death_signal
from trossen_arm_mujoco.real.arm_controller import SIDES
from trossen_arm_mujoco.real.preflight import check_loopback

__all__ = ["ArmPair", "CameraReader", "ControlClient", "KitLink", "check_loopback", "start_kit"]

#: Seconds to wait for a started ``serve`` to print its first line.
START_TIMEOUT_S = 120.0
#: Seconds a stopped ``serve`` may take to exit (and print its report) before it is killed.
STOP_TIMEOUT_S = 30.0


@dataclass(frozen=True)
class KitLink:
    """Where the served kit is: the arms' addresses, the camera stream, the control
    channel (all loopback); ``connect``: use a ``serve`` already running there."""

    left_ip: str = "127.0.0.2"
    right_ip: str = "127.0.0.3"
    host: str = "127.0.0.1"
    camera_port: int = 5555
    control_port: int = 5556
    connect: bool = False

    def checked(self) -> KitLink:
        """This link, after checking every address is loopback, the arms' addresses differ
        and the ports are in 1-65535 (UserError naming the flag otherwise)."""
        for flag, ip in (
            ("--left_ip", self.left_ip),
            ("--right_ip", self.right_ip),
            ("--kit_host", self.host),
        ):
            check_loopback(ip, flag)
        if self.left_ip == self.right_ip:
            raise UserError("--left_ip and --right_ip must differ")
        for flag, port in (
            ("--camera_port", self.camera_port),
            ("--control_port", self.control_port),
        ):
            if not 1 <= port <= 65535:
                raise UserError(f"{flag} must be in 1..65535, got {port}")
        return self


def start_kit(
    link: KitLink, task: str, cams: tuple[str, ...], size: tuple[int, int], fps: float
) -> subprocess.Popen:
    """``serve`` in a child process for ``link``, publishing ``cams`` at ``size`` and ``fps``;
    returns once it serves. A child that exits first is a ``UserError`` with its last line.
    The child ends with this process (see the module doc); on Linux with the thread that
    called this one, so call it from the thread that will :func:`stop_kit` it.

    Args:
        link: the addresses and ports to serve on (loopback).
        task: the registered task to serve.
        cams: the cameras to publish.
        size: (H, W) of the images, pixels.
        fps: the camera stream's rate (Hz).

    Raises:
        UserError: the child exits before it serves (with its last line).
    """
    from trossen_arm_mujoco.eval.arm_tasks import is_arm_task

    # a single arm's task: its one arm on the left arm's address
    arms = ["--ip", link.left_ip] if is_arm_task(task) else []
    arms = arms or ["--left_ip", link.left_ip, "--right_ip", link.right_ip]
    cmd = [
        sys.executable,
        "-m",
        "trossen_arm_mujoco.scripts.serve",
        "--task_name",
        task,
        *arms,
        "--control_port",
        str(link.control_port),
        "--control_host",
        link.host,
    ]
    if cams:
        cmd += [
            "--cameras",
            ",".join(cams),
            "--image_size",
            f"{size[0]}x{size[1]}",
            "--camera_fps",
            f"{fps:g}",
            "--camera_port",
            str(link.camera_port),
            "--camera_host",
            link.host,
        ]
    cmd += ["--parent_pid", str(os.getpid())]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_child_setup(os.getpid()),
    )
    lines: list[str] = []
    errors: list[str] = []
    for stream, into in ((proc.stdout, lines), (proc.stderr, errors)):  # drained: never full
        threading.Thread(target=into.extend, args=(stream,), daemon=True).start()
    proc.lines = lines  # type: ignore[attr-defined]  (what serve printed, for stop_kit)
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        if any(line.startswith("serving ") for line in lines):
            return proc
        if proc.poll() is not None:
            time.sleep(0.2)  # the readers catch the last lines
            why = (errors or lines or ["no output"])[-1].strip().removeprefix("error: ")
            raise UserError(f"the served kit did not start: {why}")
        time.sleep(0.05)
    stop_kit(proc)
    raise UserError(f"the served kit did not start within {START_TIMEOUT_S:.0f} s")


def _child_setup(parent: int) -> Callable[[], None] | None:
    """What the ``serve`` child runs between fork and exec (None where there is nothing to
    do): SIGTERM back to its default action (an ignored one would stay ignored through
    exec, and ``serve`` keeps ignored signals ignored), and on Linux the kernel asked to
    send it SIGTERM when ``parent`` ends; a parent already gone ends the child at once.
    Everything it needs is looked up here, before the fork."""
    if os.name != "posix":  # no fork: nothing runs in between (and no preexec_fn)
        return None
    request = parent_death_signal(signal.SIGTERM)

    def setup() -> None:
        try:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
        except ValueError:  # not Python's main thread: the inherited disposition stays
            pass
        if request is not None:
            request()
        if os.getppid() != parent:  # the parent ended before the request took effect
            os._exit(1)

    return setup


def stop_kit(proc: subprocess.Popen | None) -> list[str]:
    """Stop a kit started by :func:`start_kit` (SIGTERM, then kill after
    ``STOP_TIMEOUT_S``); the lines it printed (its last ones: the camera stream's rate and
    frame age, its real-time factor)."""
    if proc is None:
        return []
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)  # SIGINT may be ignored (inherited: a background job)
        try:
            proc.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    time.sleep(0.2)  # the reader catches the last lines
    return [line.strip() for line in getattr(proc, "lines", [])]


class ControlClient:
    """The kit's episode control channel (``twin.episode_control``).

    Args:
        host: the channel's loopback address.
        port: its TCP port.
        timeout: seconds to wait for a reply.
    """

    def __init__(self, host: str, port: int, timeout: float = 15.0) -> None:
        host = check_loopback(host, "--kit_host")
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as exc:
            raise UserError(
                f"no episode control channel on {host}:{port} ({exc}); start the "
                "kit with serve --control_port PORT"
            ) from None
        self.file = self.sock.makefile("rwb")

    def request(self, cmd: str, **fields: Any) -> dict[str, Any]:
        """Send one request; its reply (``ok`` true), else a ``UserError`` with the kit's."""
        try:
            self.file.write((json.dumps({"cmd": cmd, **fields}) + "\n").encode())
            self.file.flush()
            line = self.file.readline()
        except OSError as exc:
            raise UserError(f"the served kit's control channel failed ({exc})") from None
        if not line:
            raise UserError("the served kit closed its control channel (did serve stop?)")
        reply = json.loads(line)
        if not reply.get("ok"):
            raise UserError(f"the served kit refused {cmd}: {reply.get('error')}")
        return reply

    def close(self) -> None:
        """Close the control connection (errors ignored)."""
        try:
            self.file.close()
            self.sock.close()
        except OSError:
            pass


class CameraReader:
    """Latest image of each camera on the stream at ``tcp://host:port`` (a daemon thread
    decodes every message; see ``twin.camera_stream`` for the format and colours)."""

    def __init__(self, host: str, port: int) -> None:
        try:
            import zmq
        except ImportError:
            raise UserError(
                "--backend wire with cameras needs pyzmq: pip install 'trossen-arm-mujoco[cameras]'"
            ) from None
        self._zmq = zmq
        self._ctx = zmq.Context()
        self._sock = self._ctx.socket(zmq.SUB)
        self._sock.setsockopt_string(zmq.SUBSCRIBE, "")
        self._sock.setsockopt(zmq.RCVTIMEO, 200)
        self._sock.connect(f"tcp://{check_loopback(host, '--kit_host')}:{port}")
        self._lock = threading.Lock()
        self.latest: dict[str, tuple[np.ndarray, float]] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wire-cameras", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from PIL import Image

        while not self._stop.is_set():
            try:
                msg = json.loads(self._sock.recv_string())
            except self._zmq.Again:
                continue
            except self._zmq.ZMQError:
                return
            stamps = msg.get("timestamps", {})
            for name, text in msg.get("images", {}).items():
                with Image.open(io.BytesIO(base64.b64decode(text))) as img:
                    rgb = np.ascontiguousarray(np.asarray(img.convert("RGB"))[..., ::-1])
                with self._lock:
                    self.latest[name] = (rgb, float(stamps.get(name, 0.0)))

    def frames(self) -> dict[str, tuple[np.ndarray, float]]:
        """Camera -> (latest RGB image, its timestamp)."""
        with self._lock:
            return dict(self.latest)

    def wait_newer(self, names: tuple[str, ...], after: float, timeout: float) -> bool:
        """Wait until every camera of ``names`` has an image stamped after ``after``.

        Args:
            names: the cameras to wait for.
            after: wall-clock time (s, ``time.time()``) the images must be stamped after.
            timeout: seconds to wait; False when they are not all newer by then.
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            got = self.frames()
            if all(n in got and got[n][1] > after for n in names):
                return True
            time.sleep(0.005)
        return False

    def close(self) -> None:
        """Stop the reader thread and close its ZeroMQ socket and context."""
        self._stop.set()
        self._thread.join(2.0)
        self._sock.close(0)
        self._ctx.term()


@contextlib.contextmanager
def _side_of_error(side: str, errors: tuple[type[BaseException], ...]) -> Iterator[None]:
    """Tag an arm's error with the arm it came from (``exc.side``)."""
    try:
        yield
    except errors as exc:
        try:
            exc.side = side  # type: ignore[attr-defined]
        except AttributeError:  # an exception type without a __dict__
            pass
        raise


class ArmPair:
    """Both arms through ``trossen_arm`` (``configure`` with the follower preset, position
    mode); :meth:`read` gives 14 values (left then right: 6 joints rad, gripper m).
    ``right_ip`` None: one arm (a single arm's task), 7 values, its errors side ``""``.

    Args:
        left_ip: the left arm's loopback address (a single arm's one arm).
        right_ip: the right arm's; None: one arm.
        timeout: the driver's timeout (s).
    """

    def __init__(self, left_ip: str, right_ip: str | None, timeout: float = 10.0) -> None:
        from trossen_arm_mujoco.real.driver import (
            DEFAULT_END_EFFECTOR,
            DEFAULT_MODEL,
            import_trossen_arm,
            resolve_presets,
        )

        self._ta = ta = import_trossen_arm()
        self._presets = resolve_presets(ta, DEFAULT_MODEL, DEFAULT_END_EFFECTOR)
        self.ips = [check_loopback(left_ip, "--left_ip")]
        if right_ip is not None:
            self.ips.append(check_loopback(right_ip, "--right_ip"))
        self.sides = SIDES if right_ip is not None else ("",)
        self.timeout = timeout
        #: What the driver raises once a controller is in an error state.
        self.errors: tuple[type[BaseException], ...] = (RuntimeError,)
        self.drivers: list[Any] = []
        self.connect()

    def connect(self) -> None:
        """(Re)configure both arms, clearing any error state, in position mode."""
        self.close()
        try:
            for ip in self.ips:
                driver = self._ta.TrossenArmDriver()
                self.drivers.append(driver)
                driver.configure(*self._presets, ip, True, self.timeout)
                driver.set_all_modes(self._ta.Mode.position)
        except Exception as exc:
            self.close()
            raise UserError(
                f"cannot drive the served kit's arms ({' '.join(str(exc).split())})"
            ) from None

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities, 14 values each. An arm's error names its side
        (``exc.side``, ``left`` or ``right``)."""
        pos, vel = [], []
        for side, d in zip(self.sides, self.drivers):
            with _side_of_error(side, self.errors):
                pos.append(np.asarray(d.get_all_positions()))
                vel.append(np.asarray(d.get_all_velocities()))
        return np.concatenate(pos), np.concatenate(vel)

    def command(self, values14: np.ndarray, goal_time: float) -> None:
        """Send 7 goal positions to each arm (non-blocking, reached after ``goal_time`` s);
        an arm's error names its side (``exc.side``)."""
        for i, (side, driver) in enumerate(zip(self.sides, self.drivers)):
            goal = [float(v) for v in values14[7 * i : 7 * i + 7]]
            with _side_of_error(side, self.errors):
                driver.set_all_positions(goal, float(goal_time), False)

    def close(self) -> None:
        """``cleanup()`` each arm's driver (errors ignored) and forget them."""
        for driver in self.drivers:
            try:
                driver.cleanup()
            except Exception:
                pass
        self.drivers = []
