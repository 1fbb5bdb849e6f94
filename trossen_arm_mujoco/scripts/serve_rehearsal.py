"""``serve``'s rehearsal flags: the camera stream (``--cameras``) and the episode control
channel (``--control_port``), checked, built, stopped (``twin.camera_stream``,
``twin.episode_control``; docs/rehearsal.md). Loopback addresses only."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from trossen_arm_mujoco.errors import UserError

__all__ = ["add_rehearsal_flags", "build_rehearsal", "check_rehearsal_flags", "stop_rehearsal"]

#: Defaults of the flags that only mean something with ``--cameras``.
CAMERA_DEFAULTS: dict[str, Any] = {
    "camera_fps": 30.0,
    "camera_port": 5555,
    "camera_host": "127.0.0.1",
}


def add_rehearsal_flags(p: argparse.ArgumentParser) -> None:
    """``--cameras``, ``--camera_fps``, ``--camera_port``, ``--camera_host``,
    ``--control_port``, ``--control_host``."""
    p.add_argument(
        "--cameras",
        default=None,
        metavar="NAMES",
        help="publish these cameras (comma list) over ZeroMQ in LeRobot's ZMQ "
        "camera protocol, at --image_size (docs/rehearsal.md)",
    )
    p.add_argument(
        "--camera_fps",
        type=float,
        default=CAMERA_DEFAULTS["camera_fps"],
        help="with --cameras: frames published per second (default 30)",
    )
    p.add_argument(
        "--camera_port",
        type=int,
        default=CAMERA_DEFAULTS["camera_port"],
        help="with --cameras: TCP port of the stream (default 5555)",
    )
    p.add_argument(
        "--camera_host",
        default=CAMERA_DEFAULTS["camera_host"],
        help="with --cameras: loopback address of the stream (default 127.0.0.1)",
    )
    p.add_argument(
        "--control_port",
        type=int,
        default=None,
        help="serve the episode control channel (start / end / status, JSON lines) "
        "on this TCP port; with --record, one episode per start .. end",
    )
    p.add_argument(
        "--control_host",
        default="127.0.0.1",
        help="with --control_port: loopback address (default 127.0.0.1)",
    )


def check_rehearsal_flags(args: argparse.Namespace) -> None:
    """The flags checked before anything is served (one-line ``UserError``s): camera flags
    without ``--cameras``, non-loopback addresses, a missing pyzmq."""
    from trossen_arm_mujoco.twin.serving import check_loopback

    if args.cameras is None:
        for flag, default in CAMERA_DEFAULTS.items():
            if getattr(args, flag) != default:
                raise UserError(f"--{flag} needs --cameras NAMES")
    else:
        from trossen_arm_mujoco.twin.camera_stream import import_zmq

        check_loopback(args.camera_host, "--camera_host")
        import_zmq()
    if args.control_port is None and args.control_host != "127.0.0.1":
        raise UserError("--control_host needs --control_port PORT")
    if args.control_port is not None:
        check_loopback(args.control_host, "--control_host")


def build_rehearsal(
    args: argparse.Namespace, world: Any, recorder: Any, say: Callable[[str], None]
) -> tuple[Any, Any]:
    """The camera stream and the control channel the flags ask for (None where not asked;
    not started). A bad camera name or a port in use is a one-line ``UserError``.

    Args:
        args: the parsed ``serve`` flags.
        world: the served kit's world.
        recorder: the ``--record`` recorder, or None.
        say: prints one line.
    """
    stream = control = None
    if args.cameras is not None:
        from trossen_arm_mujoco.scripts.common_options import image_size
        from trossen_arm_mujoco.twin.camera_stream import CameraStream

        names = [c.strip() for c in args.cameras.split(",") if c.strip()]
        h, w = image_size(args.image_size)
        stream = CameraStream(
            world, names, h, w, args.camera_fps, args.camera_port, args.camera_host
        )
    if args.control_port is not None:
        from trossen_arm_mujoco.twin.episode_control import EpisodeControl

        try:
            control = EpisodeControl(world, args.control_port, args.control_host, recorder, say)
        except BaseException:
            if stream is not None:
                stream.stop()
            raise
    return stream, control


def stop_rehearsal(stream: Any, control: Any, say: Callable[[str], None]) -> None:
    """Stop the control channel and the camera stream (one line: its measured rate and
    frame age; another if it had stopped early).

    Args:
        stream: the camera stream, or None.
        control: the control channel, or None.
        say: prints one line.
    """
    if control is not None:
        control.stop()
    if stream is not None:
        stats = stream.stop()
        say(stats.line(stream.fps))
        if stream.error is not None:
            say(f"warning: the camera stream stopped early: {stream.error}")
